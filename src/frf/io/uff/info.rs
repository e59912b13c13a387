//! Datasets kept for display and for the record: 151 (header: model, programs, dates) and 82
//! (trace lines between nodes).

use super::block::{Block, Ctx};
use super::lex::{At, fields, text};
use super::types::{UffHeader, UffTraceLine};
use super::{UffError, UffFile};

/// Dataset 151: seven records of text (model file name, description, program that created the
/// database, its creation and last-save dates, program that wrote the file, date written).
/// Blank records are kept blank; a short dataset keeps what it has.
pub(super) fn parse_151(b: &Block<'_>, ctx: &mut Ctx<'_>, out: &mut UffFile) {
    let rec = |k: usize| {
        b.lines
            .get(k)
            .map_or(String::new(), |(_, r)| text(r).trim().to_string())
    };
    let h = UffHeader {
        model: rec(0),
        description: rec(1),
        database_program: rec(2),
        database_created: rec(3),
        database_saved: rec(4),
        program: rec(5),
        written: rec(6),
        line: b.header_line,
    };
    if out.header.is_some() {
        ctx.warn(format!(
            "{}:{}: a second header (dataset 151); the last one is kept",
            ctx.file, b.header_line
        ));
    }
    out.header = Some(h);
}

/// Dataset 82: Format(3I10) (trace line number, number of nodes, colour), Format(80A1) (ID
/// line), then the node labels Format(8I10), 0 meaning "move to the next node"; repeated.
pub(super) fn parse_82(b: &Block<'_>, ctx: &Ctx<'_>, out: &mut UffFile) -> Result<(), UffError> {
    let lines = &b.lines;
    let mut i = 0;
    while i < lines.len() {
        let (no, raw) = lines[i];
        i += 1;
        if raw.trim_ascii().is_empty() {
            continue;
        }
        let at1 = At {
            file: ctx.file,
            line: no,
            dataset: 82,
            record: "record 1",
        };
        let f = fields(raw, &[10, 10, 10]);
        let id = at1.label(&f[0], "field 1 (trace line number)")?;
        let count = at1.small(&f[1], "field 2 (number of nodes)")? as usize;
        let color = at1.small(&f[2], "field 3 (colour)")?;
        let name = lines
            .get(i)
            .map_or(String::new(), |(_, r)| text(r).trim().to_string());
        i += 1;
        let mut nodes = Vec::with_capacity(count.min(4096));
        while nodes.len() < count {
            let Some(&(l, r)) = lines.get(i) else {
                return Err(At {
                    line: b.end,
                    record: "record 3",
                    ..at1
                }
                .err(
                    "node labels",
                    format!("{} labels before the closing `    -1`", nodes.len()),
                    format!("{count} node labels (record 1 field 2)"),
                ));
            };
            i += 1;
            let at3 = At {
                line: l,
                record: "record 3",
                ..at1
            };
            for tok in text(r).split_whitespace() {
                if nodes.len() == count {
                    break;
                }
                nodes.push(at3.label(tok, &format!("node {}", nodes.len() + 1))?);
            }
        }
        out.trace_lines.push(UffTraceLine {
            id,
            color,
            name,
            nodes,
            line: no,
        });
    }
    Ok(())
}
