//! Source positions of YAML nodes, so that every error names the file, line and column.
//!
//! The document is scanned once with yaml-rust2's event parser; each mapping key and each value is
//! recorded under its path (`["stages", "noise", "with", "level"]`, sequence items by index).
//! Duplicate keys, which serde would silently merge, are collected here too.

use std::collections::HashMap;
use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

/// A 1-based line and column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Pos {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1.
    pub col: usize,
}

/// Positions of keys and values by path.
#[derive(Clone, Debug, Default)]
pub struct Locator {
    keys: HashMap<Vec<String>, Pos>,
    values: HashMap<Vec<String>, Pos>,
    /// Keys that occur twice in one mapping: path of the second occurrence and both positions.
    pub duplicates: Vec<(Vec<String>, Pos, Pos)>,
}

enum Frame {
    Map {
        key: Option<String>,
        seen: HashMap<String, Pos>,
    },
    Seq {
        index: usize,
    },
}

struct Recorder<'a> {
    loc: &'a mut Locator,
    stack: Vec<Frame>,
    path: Vec<String>,
}

fn pos(m: Marker) -> Pos {
    Pos {
        line: m.line(),
        col: m.col() + 1,
    }
}

impl Recorder<'_> {
    /// Handles a node (scalar or container start) at `mark`; returns the path of the node if it
    /// is a value, `None` if it was a mapping key.
    fn node(&mut self, scalar: Option<&str>, mark: Marker) -> Option<Vec<String>> {
        match self.stack.last_mut() {
            Some(Frame::Map { key, seen }) if key.is_none() => {
                let k = scalar.unwrap_or("<complex key>").to_string();
                let mut p = self.path.clone();
                p.push(k.clone());
                if let Some(first) = seen.get(&k) {
                    self.loc.duplicates.push((p.clone(), *first, pos(mark)));
                } else {
                    seen.insert(k.clone(), pos(mark));
                    self.loc.keys.entry(p).or_insert(pos(mark));
                }
                *key = Some(k);
                None
            }
            Some(Frame::Map { key, .. }) => {
                let k = key.take().unwrap_or_default();
                let mut p = self.path.clone();
                p.push(k);
                self.loc.values.entry(p.clone()).or_insert(pos(mark));
                Some(p)
            }
            Some(Frame::Seq { index }) => {
                let mut p = self.path.clone();
                p.push(index.to_string());
                *index += 1;
                self.loc.values.entry(p.clone()).or_insert(pos(mark));
                Some(p)
            }
            None => {
                self.loc.values.entry(Vec::new()).or_insert(pos(mark));
                Some(Vec::new())
            }
        }
    }
}

impl MarkedEventReceiver for Recorder<'_> {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        match ev {
            Event::Scalar(s, ..) => {
                self.node(Some(&s), mark);
            }
            Event::Alias(_) => {
                self.node(None, mark);
            }
            Event::MappingStart(..) | Event::SequenceStart(..) => {
                let is_map = matches!(ev, Event::MappingStart(..));
                if let Some(p) = self.node(None, mark) {
                    self.path = p;
                } else {
                    // A container used as a key: track it under a placeholder name.
                    self.path.push("<complex key>".into());
                }
                self.stack.push(if is_map {
                    Frame::Map {
                        key: None,
                        seen: HashMap::new(),
                    }
                } else {
                    Frame::Seq { index: 0 }
                });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.stack.pop();
                if !self.stack.is_empty() {
                    self.path.pop();
                }
            }
            _ => {}
        }
    }
}

impl Locator {
    /// Scans `text`; a YAML syntax error is returned as its position and message.
    pub fn scan(text: &str) -> Result<Locator, (Pos, String)> {
        let mut loc = Locator::default();
        let mut rec = Recorder {
            loc: &mut loc,
            stack: Vec::new(),
            path: Vec::new(),
        };
        let mut parser = Parser::new_from_str(text);
        parser.load(&mut rec, false).map_err(|e| {
            (
                Pos {
                    line: e.marker().line(),
                    col: e.marker().col() + 1,
                },
                e.info().to_string(),
            )
        })?;
        Ok(loc)
    }

    /// Position of the key at `path`, or of the nearest ancestor that has one.
    pub fn key(&self, path: &[&str]) -> Option<Pos> {
        self.find(&self.keys, path)
    }

    /// Position of the value at `path`, or of the nearest ancestor that has one.
    pub fn value(&self, path: &[&str]) -> Option<Pos> {
        self.find(&self.values, path)
    }

    fn find(&self, map: &HashMap<Vec<String>, Pos>, path: &[&str]) -> Option<Pos> {
        (0..=path.len()).rev().find_map(|n| {
            let p: Vec<String> = path[..n].iter().map(|s| s.to_string()).collect();
            map.get(&p).or_else(|| self.keys.get(&p)).copied()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "name: x\nstages:\n  a:\n    kind: modes\n    with: {count: 3}\n  b:\n    kind: frf\n    with:\n      lines: [1, 2]\n";

    #[test]
    fn keys_and_values_have_positions() {
        let l = Locator::scan(DOC).unwrap();
        assert_eq!(
            l.key(&["stages", "b", "kind"]),
            Some(Pos { line: 7, col: 5 })
        );
        assert_eq!(
            l.value(&["stages", "b", "kind"]),
            Some(Pos { line: 7, col: 11 })
        );
        assert_eq!(
            l.value(&["stages", "a", "with", "count"]),
            Some(Pos { line: 5, col: 19 })
        );
        assert_eq!(
            l.value(&["stages", "b", "with", "lines", "1"]),
            Some(Pos { line: 9, col: 18 })
        );
        // Unknown deeper paths fall back to the nearest ancestor.
        assert_eq!(
            l.value(&["stages", "a", "with", "nope"]),
            Some(Pos { line: 5, col: 11 })
        );
    }

    #[test]
    fn duplicate_keys_are_found() {
        let l = Locator::scan("stages:\n  a: 1\n  a: 2\n").unwrap();
        assert_eq!(l.duplicates.len(), 1);
        assert_eq!(
            l.duplicates[0].0,
            vec!["stages".to_string(), "a".to_string()]
        );
        assert_eq!(l.duplicates[0].2.line, 3);
    }

    #[test]
    fn syntax_errors_have_a_position() {
        let (p, msg) = Locator::scan("a: [1, 2\nb: 3\n").unwrap_err();
        assert!(p.line >= 1 && !msg.is_empty());
    }
}
