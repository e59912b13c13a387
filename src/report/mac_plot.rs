//! The MAC matrix (1.18) of two mode sets as a heat map for papers: one cell per (reference,
//! predicted) elastic mode pair on a `[0, 1]` colour scale with a colour bar, the chosen pairs
//! outlined in red, the MAC printed in each cell while the matrix is small enough to read.
//!
//! Sized to stay legible at a column width of about 85 mm (text of at least 7 pt there).
//! Equal inputs give byte-identical files.

use faer::MatRef;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::figure::{Figure, PlotError, backend_error, render, text_style};
use super::mesh_plot::{SEQUENTIAL, ramp};

/// What to draw.
#[derive(Clone, Debug)]
pub struct MacPlot<'a> {
    /// Figure title.
    pub title: String,
    /// MAC of reference mode `i` (row) with predicted mode `j` (column).
    pub mac: MatRef<'a, f64>,
    /// Label of each row (reference mode), e.g. its number; missing ones are numbered.
    pub reference: Vec<String>,
    /// Label of each column (predicted mode).
    pub predicted: Vec<String>,
    /// Chosen pairs `(row, column)`, outlined.
    pub pairs: Vec<(usize, usize)>,
    /// Title of the vertical axis.
    pub reference_label: String,
    /// Title of the horizontal axis.
    pub predicted_label: String,
}

const INK: RGBColor = RGBColor(33, 33, 33);
/// Outline of a chosen pair.
pub(crate) const PAIR: RGBColor = RGBColor(220, 20, 30);
const SIZE: (u32, u32) = (640, 560);
const TITLE_H: i32 = 44;
const LEFT: i32 = 92;
const BOTTOM: i32 = 84;
const BAR_W: i32 = 112;
/// Most cells per side that still get their value printed.
const ANNOTATE_MAX: usize = 8;
/// Most tick labels per axis.
const MAX_TICKS: usize = 12;

fn text<'a>(size: f64, bold: bool, pos: Pos) -> TextStyle<'a> {
    let style = if bold {
        FontStyle::Bold
    } else {
        FontStyle::Normal
    };
    text_style(size, style, INK, pos)
}

/// Renders the heat map as PNG and SVG.
pub fn mac_plot(plot: &MacPlot<'_>) -> Result<Figure, PlotError> {
    render(SIZE.0, SIZE.1, &|root| draw(root, plot), &|root| {
        draw(root, plot)
    })
}

/// The plot area `(x0, y0, x1, y1)` in pixels and the cell size.
fn area(rows: usize, cols: usize) -> ((i32, i32, i32, i32), (f64, f64)) {
    let (w, h) = (SIZE.0 as i32, SIZE.1 as i32);
    let side_w = (w - LEFT - BAR_W - 12) as f64;
    let side_h = (h - TITLE_H - BOTTOM - 8) as f64;
    // Square cells when the matrix allows, filling the larger fitting rectangle.
    let cell = (side_w / cols.max(1) as f64).min(side_h / rows.max(1) as f64);
    let (aw, ah) = (cell * cols.max(1) as f64, cell * rows.max(1) as f64);
    let x0 = LEFT + ((side_w - aw) / 2.0).round() as i32;
    let y0 = TITLE_H + 8;
    (
        (x0, y0, x0 + aw.round() as i32, y0 + ah.round() as i32),
        (cell, cell),
    )
}

/// Every `k`-th index labelled so that at most [`MAX_TICKS`] labels show.
fn tick_every(n: usize) -> usize {
    n.div_ceil(MAX_TICKS).max(1)
}

fn label(labels: &[String], i: usize) -> String {
    labels
        .get(i)
        .cloned()
        .unwrap_or_else(|| (i + 1).to_string())
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &MacPlot<'_>,
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(backend_error)?;
    let centre = Pos::new(HPos::Center, VPos::Center);
    let (rows, cols) = (plot.mac.nrows(), plot.mac.ncols());
    let ((x0, y0, x1, y1), (cw, ch)) = area(rows, cols);
    root.draw(&Text::new(
        plot.title.clone(),
        ((x0 + x1) / 2, TITLE_H / 2),
        text(22.0, true, centre),
    ))
    .map_err(backend_error)?;
    let cell = |i: usize, j: usize| {
        let (a, b) = (
            x0 + (j as f64 * cw).round() as i32,
            y0 + (i as f64 * ch).round() as i32,
        );
        let (c, d) = (
            x0 + ((j + 1) as f64 * cw).round() as i32,
            y0 + ((i + 1) as f64 * ch).round() as i32,
        );
        (a, b, c, d)
    };
    // Cells are polygons (the colour bar is made of rectangles), one per matrix entry.
    for i in 0..rows {
        for j in 0..cols {
            let (a, b, c, d) = cell(i, j);
            let v = plot.mac[(i, j)];
            root.draw(&Polygon::new(
                vec![(a, b), (c, b), (c, d), (a, d)],
                ramp(&SEQUENTIAL, v).filled(),
            ))
            .map_err(backend_error)?;
            if rows.max(cols) <= ANNOTATE_MAX && v.is_finite() {
                // Dark text on the light end of the ramp, white on the dark end.
                let ink = if v > 0.6 { INK } else { WHITE };
                root.draw(&Text::new(
                    format!("{v:.2}"),
                    ((a + c) / 2, (b + d) / 2),
                    text_style(16.0, FontStyle::Normal, ink, centre),
                ))
                .map_err(backend_error)?;
            }
        }
    }
    if rows == 0 || cols == 0 {
        root.draw(&Text::new(
            "no elastic mode to compare".to_string(),
            ((x0 + x1) / 2, (y0 + y1) / 2),
            text(18.0, false, centre),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Rectangle::new([(x0, y0), (x1, y1)], INK.stroke_width(1)))
        .map_err(backend_error)?;
    for &(i, j) in &plot.pairs {
        if i < rows && j < cols {
            let (a, b, c, d) = cell(i, j);
            root.draw(&Rectangle::new(
                [(a + 1, b + 1), (c - 1, d - 1)],
                PAIR.stroke_width(3),
            ))
            .map_err(backend_error)?;
        }
    }
    // Ticks: mode labels under the columns and left of the rows.
    let (every_r, every_c) = (tick_every(rows), tick_every(cols));
    for j in (0..cols).step_by(every_c) {
        let (a, _, c, _) = cell(0, j);
        root.draw(&Text::new(
            label(&plot.predicted, j),
            ((a + c) / 2, y1 + 6),
            text(18.0, false, Pos::new(HPos::Center, VPos::Top)),
        ))
        .map_err(backend_error)?;
    }
    for i in (0..rows).step_by(every_r) {
        let (_, b, _, d) = cell(i, 0);
        root.draw(&Text::new(
            label(&plot.reference, i),
            (x0 - 8, (b + d) / 2),
            text(18.0, false, Pos::new(HPos::Right, VPos::Center)),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Text::new(
        plot.predicted_label.clone(),
        ((x0 + x1) / 2, y1 + 50),
        text(20.0, false, centre),
    ))
    .map_err(backend_error)?;
    let vertical = text(20.0, false, centre).transform(FontTransform::Rotate270);
    root.draw(&Text::new(
        plot.reference_label.clone(),
        (24, (y0 + y1) / 2),
        vertical,
    ))
    .map_err(backend_error)?;
    colour_bar(root, y0, y1, !plot.pairs.is_empty())
}

/// The `[0, 1]` colour bar right of the matrix, its ticks, its label and the pair key.
fn colour_bar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    y0: i32,
    y1: i32,
    pairs: bool,
) -> Result<(), PlotError> {
    let bx = SIZE.0 as i32 - BAR_W + 8;
    let (by0, by1) = (y0 + 30, y1 - 60);
    let steps = 100;
    for k in 0..steps {
        let (t0, t1) = (k as f64 / steps as f64, (k + 1) as f64 / steps as f64);
        let ya = by1 - ((by1 - by0) as f64 * t1).round() as i32;
        let yb = by1 - ((by1 - by0) as f64 * t0).round() as i32;
        root.draw(&Rectangle::new(
            [(bx, ya), (bx + 22, yb)],
            ramp(&SEQUENTIAL, (t0 + t1) / 2.0).filled(),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Rectangle::new(
        [(bx, by0), (bx + 22, by1)],
        INK.stroke_width(1),
    ))
    .map_err(backend_error)?;
    for k in 0..=4 {
        let t = k as f64 / 4.0;
        let y = by1 - ((by1 - by0) as f64 * t).round() as i32;
        root.draw(&PathElement::new(
            vec![(bx + 22, y), (bx + 27, y)],
            INK.stroke_width(1),
        ))
        .map_err(backend_error)?;
        root.draw(&Text::new(
            format!("{t:.2}"),
            (bx + 30, y),
            text(18.0, false, Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(backend_error)?;
    }
    root.draw(&Text::new(
        "MAC".to_string(),
        (bx + 11, by0 - 18),
        text(20.0, false, Pos::new(HPos::Center, VPos::Center)),
    ))
    .map_err(backend_error)?;
    if pairs {
        let ly = by1 + 30;
        root.draw(&Rectangle::new(
            [(bx, ly - 9), (bx + 18, ly + 9)],
            PAIR.stroke_width(3),
        ))
        .map_err(backend_error)?;
        root.draw(&Text::new(
            "pair".to_string(),
            (bx + 26, ly),
            text(18.0, false, Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(backend_error)?;
    }
    Ok(())
}

/// Checks for figure tests: SVG well-formedness and counts of drawn elements.
#[cfg(test)]
pub(crate) mod check {
    /// Whether `svg` is a well-formed XML document with an `<svg>` root: every tag closed in
    /// order, attribute values quoted, nothing but whitespace after the root. Returns the
    /// number of elements by name.
    pub(crate) fn svg_elements(
        svg: &str,
    ) -> Result<std::collections::BTreeMap<String, usize>, String> {
        let mut counts = std::collections::BTreeMap::new();
        let mut stack: Vec<String> = Vec::new();
        let mut rest = svg.trim_start();
        if let Some(r) = rest.strip_prefix("<?xml") {
            rest = &r[r.find("?>").ok_or("unterminated XML declaration")? + 2..];
        }
        let mut root_seen = false;
        while let Some(open) = rest.find('<') {
            if stack.is_empty() && root_seen && !rest[..open].trim().is_empty() {
                return Err("text after the root element".into());
            }
            rest = &rest[open + 1..];
            if let Some(r) = rest.strip_prefix("!--") {
                rest = &r[r.find("-->").ok_or("unterminated comment")? + 3..];
                continue;
            }
            let close = tag_end(rest).ok_or("unterminated tag")?;
            let tag = &rest[..close];
            rest = &rest[close + 1..];
            if let Some(name) = tag.strip_prefix('/') {
                let top = stack.pop().ok_or("closing tag without opening")?;
                if top != name.trim() {
                    return Err(format!("</{}> closes <{top}>", name.trim()));
                }
                continue;
            }
            let (body, empty) = match tag.strip_suffix('/') {
                Some(b) => (b, true),
                None => (tag, false),
            };
            let name: String = body.chars().take_while(|c| !c.is_whitespace()).collect();
            if name.is_empty()
                || !name
                    .chars()
                    .all(|c| c.is_alphanumeric() || ":-_".contains(c))
            {
                return Err(format!("bad element name in <{tag}>"));
            }
            check_attributes(&body[name.len()..])?;
            if stack.is_empty() {
                if root_seen {
                    return Err("two root elements".into());
                }
                if name != "svg" {
                    return Err(format!("root element is <{name}>, not <svg>"));
                }
                root_seen = true;
            }
            *counts.entry(name.clone()).or_insert(0) += 1;
            if !empty {
                stack.push(name);
            }
        }
        if !stack.is_empty() {
            return Err(format!("unclosed <{}>", stack.join("> <")));
        }
        if !root_seen {
            return Err("no <svg> element".into());
        }
        Ok(counts)
    }

    /// The index of the `>` ending a tag, outside quoted attribute values.
    fn tag_end(s: &str) -> Option<usize> {
        let mut quote = None;
        for (i, c) in s.char_indices() {
            match (quote, c) {
                (None, '"' | '\'') => quote = Some(c),
                (Some(q), c) if c == q => quote = None,
                (None, '>') => return Some(i),
                _ => {}
            }
        }
        None
    }

    fn check_attributes(mut s: &str) -> Result<(), String> {
        loop {
            s = s.trim_start();
            if s.is_empty() {
                return Ok(());
            }
            let eq = s
                .find('=')
                .ok_or_else(|| format!("attribute without value: {s}"))?;
            let name = s[..eq].trim();
            if name.is_empty() || name.contains(char::is_whitespace) {
                return Err(format!("bad attribute name {name:?}"));
            }
            s = s[eq + 1..].trim_start();
            let q = s.chars().next().ok_or("missing attribute value")?;
            if q != '"' && q != '\'' {
                return Err(format!("unquoted value of {name}"));
            }
            let end = s[1..].find(q).ok_or("unterminated attribute value")?;
            s = &s[end + 2..];
        }
    }

    /// Elements `<name …>` whose opening tag contains `needle`.
    pub(crate) fn count_with(svg: &str, name: &str, needle: &str) -> usize {
        svg.split(&format!("<{name} "))
            .skip(1)
            .filter(|t| t.split('>').next().is_some_and(|t| t.contains(needle)))
            .count()
    }

    #[test]
    fn rejects_what_is_not_well_formed() {
        assert!(svg_elements("<svg a=\"1\"><g><rect x=\"1\"/></g></svg>").is_ok());
        for bad in [
            "<svg><g></svg>",
            "<svg><rect x=1/></svg>",
            "<svg></svg><svg></svg>",
            "<g></g>",
            "<svg><rect x=\"1\"></svg>",
        ] {
            assert!(svg_elements(bad).is_err(), "{bad}");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::check::{count_with, svg_elements};
    use super::*;
    use faer::Mat;

    /// A 5 × 5 matrix: 25 cells, the three chosen pairs outlined, valid SVG and PNG of the
    /// stated size, the pair outline red in the bitmap; equal inputs give equal bytes.
    #[test]
    fn cells_and_pairs_are_drawn() {
        let mac = Mat::from_fn(
            5,
            5,
            |i, j| if i == j { 0.95 } else { 0.05 * (i + j) as f64 },
        );
        let plot = MacPlot {
            title: "MAC".into(),
            mac: mac.as_ref(),
            reference: (7..12).map(|k| k.to_string()).collect(),
            predicted: (7..12).map(|k| k.to_string()).collect(),
            pairs: vec![(0, 0), (1, 1), (3, 4)],
            reference_label: "reference mode".into(),
            predicted_label: "predicted mode".into(),
        };
        let fig = mac_plot(&plot).unwrap();
        assert_eq!(fig, mac_plot(&plot).unwrap());
        let counts = svg_elements(&fig.svg).unwrap();
        assert_eq!(counts.get("polygon"), Some(&25), "{counts:?}");
        assert_eq!(count_with(&fig.svg, "rect", "stroke=\"#DC141E\""), 3 + 1);
        assert!(fig.svg.contains(">\n11\n<") && fig.svg.contains("predicted mode"));
        let img = image::load_from_memory(&fig.png).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), SIZE);
        let ((x0, y0, _, _), (cw, _)) = area(5, 5);
        // The left edge of the outline of pair (3, 4), halfway down its cell.
        let (x, y) = (
            x0 + (4.0 * cw).round() as i32 + 2,
            y0 + (3.5 * cw).round() as i32,
        );
        assert_eq!(img.get_pixel(x as u32, y as u32).0, [220, 20, 30]);
        // Not outlined: cell (2, 4).
        let y = y0 + (2.5 * cw).round() as i32;
        assert_ne!(img.get_pixel(x as u32, y as u32).0, [220, 20, 30]);
    }

    /// `cargo test --release mac_plot::tests::write_example -- --ignored`.
    #[test]
    #[ignore = "writes an example figure to /tmp for a visual check; run on demand"]
    fn write_example() {
        let mac = Mat::from_fn(6, 6, |i, j| {
            if i == j {
                0.97 - 0.03 * i as f64
            } else {
                0.3 / (1.0 + (i as f64 - j as f64).abs())
            }
        });
        let fig = mac_plot(&MacPlot {
            title: "MAC matrix (1.18)".into(),
            mac: mac.as_ref(),
            reference: (7..13).map(|k| k.to_string()).collect(),
            predicted: (7..13).map(|k| k.to_string()).collect(),
            pairs: (0..6).map(|i| (i, i)).collect(),
            reference_label: "reference mode no.".into(),
            predicted_label: "predicted mode no.".into(),
        })
        .unwrap();
        std::fs::write("/tmp/mac_plot_example.png", &fig.png).unwrap();
    }

    /// A large matrix keeps one cell per entry but prints no values and thins the ticks.
    #[test]
    fn large_matrices_thin_their_labels() {
        let mac = Mat::from_fn(30, 20, |i, j| ((i * j) % 7) as f64 / 7.0);
        let plot = MacPlot {
            title: "MAC".into(),
            mac: mac.as_ref(),
            reference: vec![],
            predicted: vec![],
            pairs: vec![],
            reference_label: "r".into(),
            predicted_label: "p".into(),
        };
        let fig = mac_plot(&plot).unwrap();
        let counts = svg_elements(&fig.svg).unwrap();
        assert_eq!(counts.get("polygon"), Some(&600));
        assert!(!fig.svg.contains(">\n0.14\n<"), "no values printed");
        assert_eq!(tick_every(30), 3);
        assert_eq!(count_with(&fig.svg, "rect", "stroke=\"#DC141E\""), 0);
    }
}
