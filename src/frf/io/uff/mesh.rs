//! Datasets 15 and 2411 (nodes) and 2412 (elements).

use super::block::{Block, Ctx};
use super::lex::{At, fields, text};
use super::{UffBeam, UffElement, UffError, UffFile};

pub(super) fn length_conversion(ctx: &Ctx<'_>) -> Option<(f64, String)> {
    let u = ctx.units.as_ref().filter(|u| u.length_factor != 1.0)?;
    Some((
        1.0 / u.length_factor,
        format!("dataset 164 units `{}` (line {})", u.description, u.line),
    ))
}

pub(super) fn add_node(
    ctx: &mut Ctx<'_>,
    out: &mut UffFile,
    id: u64,
    xyz: [f64; 3],
    systems: [u32; 3],
    line: usize,
) -> Result<(), UffError> {
    if let Some(first) = ctx.node_lines.insert(id, line) {
        return Err(UffError::DuplicateNode {
            file: ctx.file.to_string(),
            node: id,
            first,
            second: line,
        });
    }
    let f = length_conversion(ctx).map_or(1.0, |(f, _)| f);
    let xyz = xyz.map(|x| x * f);
    ctx.node_scale.push(f);
    out.nodes.push((id, xyz));
    out.node_systems.push(systems);
    Ok(())
}

pub(super) fn note_node_conversion(ctx: &Ctx<'_>, out: &mut UffFile, b: &Block<'_>, count: usize) {
    if let Some((f, source)) = length_conversion(ctx)
        && count > 0
    {
        out.conversions.push(format!(
            "{}:{}: dataset {} coordinates of {count} nodes converted to m from {source}: ×{f:e}",
            ctx.file, b.header_line, b.number
        ));
    }
}

/// Dataset 15, nodes: Format(4I10,1P3E13.5) per node.
pub(super) fn parse_nodes_15(
    b: &Block<'_>,
    ctx: &mut Ctx<'_>,
    out: &mut UffFile,
) -> Result<(), UffError> {
    let mut count = 0;
    for &(no, raw) in &b.lines {
        if raw.trim_ascii().is_empty() {
            continue;
        }
        let at = At {
            file: ctx.file,
            line: no,
            dataset: 15,
            record: "record 1",
        };
        let f = fields(raw, &[10, 10, 10, 10, 13, 13, 13]);
        let id = at.label(&f[0], "field 1 (node label)")?;
        let systems = [
            at.small(&f[1], "field 2 (definition coordinate system)")?,
            at.small(&f[2], "field 3 (displacement coordinate system)")?,
            at.small(&f[3], "field 4 (colour)")?,
        ];
        let xyz = [
            at.real(&f[4], "field 5 (x)")?,
            at.real(&f[5], "field 6 (y)")?,
            at.real(&f[6], "field 7 (z)")?,
        ];
        add_node(ctx, out, id, xyz, systems, no)?;
        count += 1;
    }
    note_node_conversion(ctx, out, b, count);
    Ok(())
}

/// Dataset 2411, nodes in double precision: Format(4I10) then Format(1P3D25.16) per node.
pub(super) fn parse_nodes_2411(
    b: &Block<'_>,
    ctx: &mut Ctx<'_>,
    out: &mut UffFile,
) -> Result<(), UffError> {
    let lines: Vec<(usize, &[u8])> = b
        .lines
        .iter()
        .copied()
        .filter(|(_, raw)| !raw.trim_ascii().is_empty())
        .collect();
    let mut count = 0;
    for pair in lines.chunks(2) {
        let (no, raw) = pair[0];
        let at1 = At {
            file: ctx.file,
            line: no,
            dataset: 2411,
            record: "record 1",
        };
        let f = fields(raw, &[10, 10, 10, 10]);
        let id = at1.label(&f[0], "field 1 (node label)")?;
        let systems = [
            at1.small(&f[1], "field 2 (export coordinate system)")?,
            at1.small(&f[2], "field 3 (displacement coordinate system)")?,
            at1.small(&f[3], "field 4 (colour)")?,
        ];
        let Some(&(no2, raw2)) = pair.get(1) else {
            return Err(At {
                record: "record 2",
                line: b.end,
                ..at1
            }
            .err(
                "node coordinates",
                "the closing `    -1`",
                format!("the coordinates of node {id} (1P3D25.16)"),
            ));
        };
        let at2 = At {
            line: no2,
            record: "record 2",
            ..at1
        };
        let c = fields(raw2, &[25, 25, 25]);
        let xyz = [
            at2.real(&c[0], "field 1 (x)")?,
            at2.real(&c[1], "field 2 (y)")?,
            at2.real(&c[2], "field 3 (z)")?,
        ];
        add_node(ctx, out, id, xyz, systems, no)?;
        count += 1;
    }
    note_node_conversion(ctx, out, b, count);
    Ok(())
}

/// FE descriptors whose elements carry the beam record (rods and beams).
pub(super) const BEAM_DESCRIPTORS: [u32; 5] = [11, 21, 22, 23, 24];

/// Dataset 2412, elements.
pub(super) fn parse_elements_2412(
    b: &Block<'_>,
    ctx: &Ctx<'_>,
    out: &mut UffFile,
) -> Result<(), UffError> {
    let lines: Vec<(usize, &[u8])> = b
        .lines
        .iter()
        .copied()
        .filter(|(_, raw)| !raw.trim_ascii().is_empty())
        .collect();
    let mut i = 0;
    while i < lines.len() {
        let (no, raw) = lines[i];
        i += 1;
        let at1 = At {
            file: ctx.file,
            line: no,
            dataset: 2412,
            record: "record 1",
        };
        let f = fields(raw, &[10; 6]);
        let id = at1.label(&f[0], "field 1 (element label)")?;
        let descriptor = at1.small(&f[1], "field 2 (FE descriptor id)")?;
        let physical_property = at1.small(&f[2], "field 3 (physical property table)")?;
        let material_property = at1.small(&f[3], "field 4 (material property table)")?;
        let color = at1.small(&f[4], "field 5 (colour)")?;
        let count = at1.small(&f[5], "field 6 (number of nodes)")?;
        if count == 0 {
            return Err(at1.err("field 6 (number of nodes)", 0, "at least 1 node"));
        }
        let count = count as usize;
        let rest_of = |what: &str| {
            At {
                line: b.end,
                record: "record 2",
                ..at1
            }
            .err(
                what.to_string(),
                "the closing `    -1`",
                format!("the rest of element {id}"),
            )
        };
        let beam = if BEAM_DESCRIPTORS.contains(&descriptor) {
            let (no2, raw2) = take(&lines, &mut i).ok_or_else(|| rest_of("beam record"))?;
            let at2 = At {
                line: no2,
                record: "record 2 (beam)",
                ..at1
            };
            let g = fields(raw2, &[10, 10, 10]);
            Some(UffBeam {
                orientation_node: at2.label(&g[0], "field 1 (beam orientation node)")?,
                fore_section: at2.small(&g[1], "field 2 (fore-end cross section)")?,
                aft_section: at2.small(&g[2], "field 3 (aft-end cross section)")?,
            })
        } else {
            None
        };
        let mut nodes = Vec::new();
        while nodes.len() < count {
            let (nl, nraw) = take(&lines, &mut i).ok_or_else(|| rest_of("node labels"))?;
            let at3 = At {
                line: nl,
                record: if beam.is_some() {
                    "record 3"
                } else {
                    "record 2"
                },
                ..at1
            };
            nodes.extend(node_labels(&at3, nraw, count - nodes.len(), id, count)?);
        }
        out.elements.push(UffElement {
            id,
            descriptor,
            physical_property,
            material_property,
            color,
            nodes,
            beam,
            line: no,
        });
    }
    Ok(())
}

pub(super) fn take<'a>(lines: &[(usize, &'a [u8])], i: &mut usize) -> Option<(usize, &'a [u8])> {
    let l = lines.get(*i).copied()?;
    *i += 1;
    Some(l)
}

/// One line of an element's node labels: up to 8 of the `left` still wanted, as
/// whitespace-separated labels when the line holds exactly as many, else in `8I10` columns,
/// else as many whitespace-separated labels as it holds (at most `left`).
fn node_labels(
    at: &At<'_>,
    raw: &[u8],
    left: usize,
    id: u64,
    count: usize,
) -> Result<Vec<u64>, UffError> {
    let want = left.min(8);
    let t = text(raw);
    let toks: Vec<&str> = t.split_whitespace().collect();
    let parsed =
        |v: &[String]| -> Option<Vec<u64>> { v.iter().map(|s| s.parse::<u64>().ok()).collect() };
    let as_tokens: Vec<String> = toks.iter().map(|s| s.to_string()).collect();
    if toks.len() == want {
        parsed(&as_tokens)
    } else {
        None
    }
    .or_else(|| parsed(&fields(raw, &vec![10; want])).filter(|v| v.len() == want))
    .or_else(|| parsed(&as_tokens).filter(|v| !v.is_empty() && v.len() <= left))
    .ok_or_else(|| {
        at.err(
            "node labels",
            t.trim(),
            format!("{want} node labels (8I10 per line) of element {id}, which has {count} nodes"),
        )
    })
}
