//! What every figure shares: the rendered [`Figure`] and [`PlotError`], the PNG/SVG output
//! from one drawing ([`render`]), the embedded fonts, the categorical palette, a linear
//! [`Axis`] with nice ticks, data extents and the pixel metrics of text and lines.
//!
//! Text uses the DejaVu Sans faces embedded by the `dejavu` crate, registered with plotters on
//! first use, so the output does not depend on the fonts installed and is byte-identical for
//! equal inputs. Nothing here touches the file system.

use std::ops::Range;
use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

use plotters::backend::{BitMapBackend, RGBPixel, SVGBackend};
use plotters::coord::Shift;
use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;
use plotters::style::register_font;
use plotters::style::text_anchor::Pos;

/// The rendered figure.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Figure {
    /// PNG file contents (8-bit RGB).
    pub png: Vec<u8>,
    /// SVG document.
    pub svg: String,
}

/// Smallest figure side in pixels.
pub const MIN_SIDE_PX: u32 = 400;
/// Largest figure side in pixels.
pub const MAX_SIDE_PX: u32 = 8000;

/// Why a figure could not be drawn (the FRF overlay's checks among them).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlotError {
    /// The measured set has no FRF or no frequency line.
    #[error(
        "nothing to draw: the measured set holds {pairs} FRF(s) on {lines} frequency line(s); give at least one FRF and one line"
    )]
    Empty {
        /// Measured FRFs.
        pairs: usize,
        /// Measured frequency lines.
        lines: usize,
    },
    /// `pairs` was given but empty.
    #[error(
        "no FRF selected: `pairs` is an empty list; request at least one of the measured FRFs {known}"
    )]
    NoneSelected {
        /// Measured FRFs.
        known: String,
    },
    /// A requested FRF is not in the measured set.
    #[error("the FRF {pair} is not in the measured set; measured FRFs are {known}")]
    UnknownPair {
        /// The requested FRF, `response/excitation`.
        pair: String,
        /// Measured FRFs.
        known: String,
    },
    /// A requested FRF is listed twice.
    #[error("the FRF {pair} is requested twice; list each FRF once")]
    DuplicatePair {
        /// The repeated FRF, `response/excitation`.
        pair: String,
    },
    /// More FRFs requested than `max_frfs`.
    #[error(
        "{requested} FRFs requested but max_frfs is {max}; request at most {max} or raise max_frfs (up to {limit})"
    )]
    TooMany {
        /// Requested FRFs.
        requested: usize,
        /// `max_frfs`.
        max: usize,
        /// [`MAX_FRFS`](super::frf_plot::MAX_FRFS).
        limit: usize,
    },
    /// `max_frfs` is 0 or beyond the palette.
    #[error(
        "max_frfs is {given}; it must be between 1 and {limit} so that every FRF gets its own colour"
    )]
    MaxFrfs {
        /// The value given.
        given: usize,
        /// [`MAX_FRFS`](super::frf_plot::MAX_FRFS).
        limit: usize,
    },
    /// Figure size out of range.
    #[error(
        "figure size {width}x{height} px is out of range; each side must be within {min}..={max} px"
    )]
    Size {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
        /// [`MIN_SIDE_PX`].
        min: u32,
        /// [`MAX_SIDE_PX`].
        max: u32,
    },
    /// The values matrix of a set does not match its lines and pairs.
    #[error(
        "the {which} set's values are {rows}x{cols} but it has {lines} frequency line(s) and {pairs} FRF(s); values must be lines x FRFs"
    )]
    Shape {
        /// `measured` or `predicted`.
        which: &'static str,
        /// Rows of `values`.
        rows: usize,
        /// Columns of `values`.
        cols: usize,
        /// Length of `freqs_hz`.
        lines: usize,
        /// Length of `pairs`.
        pairs: usize,
    },
    /// Measured and predicted sets hold different quantities.
    #[error(
        "measured FRFs are {measured} but predicted FRFs are {predicted}; overlay a prediction of the measured quantity"
    )]
    Quantity {
        /// Measured quantity name.
        measured: &'static str,
        /// Predicted quantity name.
        predicted: &'static str,
    },
    /// A drawn FRF has no prediction.
    #[error(
        "the predicted set has no FRF {pair}; predicted FRFs are {known}; request only predicted FRFs in `pairs` or predict this one"
    )]
    MissingPrediction {
        /// The FRF, `response/excitation`.
        pair: String,
        /// Predicted FRFs.
        known: String,
    },
    /// The correlation's vectors differ in length.
    #[error(
        "the correlation has {lines} frequency line(s) but {chi_s} χ_s and {chi_a} χ_a value(s); give one value of each per line"
    )]
    CorrelationShape {
        /// Length of `freqs_hz`.
        lines: usize,
        /// Length of `chi_s`.
        chi_s: usize,
        /// Length of `chi_a`.
        chi_a: usize,
    },
    /// No finite frequency among the drawn data.
    #[error("no finite frequency line to draw; frequency lines must be finite values in Hz")]
    NoFrequencies,
    /// The frequency lines span more than an `f64` can hold.
    #[error(
        "frequency lines run from {lo} to {hi} Hz, a span too wide to draw; frequencies must lie within ±8.9e307 Hz"
    )]
    FrequencySpan {
        /// Lowest finite frequency.
        lo: f64,
        /// Highest finite frequency.
        hi: f64,
    },
    /// The embedded font was rejected.
    #[error(
        "the embedded DejaVu Sans font could not be registered with plotters; the font bytes must be a valid TrueType file"
    )]
    Font,
    /// The data cannot make this figure (what is missing, and what would do).
    #[error("the data do not make this figure: {0}")]
    Input(String),
    /// The drawing backend failed.
    #[error("drawing failed: {0}; the inputs were valid, this is a fault of the plotting backend")]
    Backend(String),
    /// PNG encoding failed.
    #[error("PNG encoding failed: {0}; the RGB buffer must hold width x height x 3 bytes")]
    Encode(String),
}

/// Clears `root` to white and writes a bold figure title in a band `height` pixels high;
/// returns the area under it.
pub(crate) fn titled_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    height: u32,
    ink: &RGBColor,
) -> Result<DrawingArea<DB, Shift>, PlotError> {
    root.fill(&WHITE).map_err(backend_error)?;
    let (band, body) = root.split_vertically(height);
    band.titled(
        title,
        ("sans-serif", 20, FontStyle::Bold).into_font().color(ink),
    )
    .map_err(backend_error)?;
    Ok(body)
}

/// Draws one figure on the bitmap backend (see [`render`]).
pub(crate) type BitmapDrawing<'a> = dyn for<'b, 'c> Fn(&'c DrawingArea<BitMapBackend<'b, RGBPixel>, Shift>) -> Result<(), PlotError>
    + 'a;
/// Draws one figure on the SVG backend (see [`render`]).
pub(crate) type SvgDrawing<'a> =
    dyn for<'b, 'c> Fn(&'c DrawingArea<SVGBackend<'b>, Shift>) -> Result<(), PlotError> + 'a;

/// Renders a figure of `w × h` pixels as PNG and SVG: `bitmap` and `svg` are the same drawing
/// (a generic function instantiated for each backend). Every drawing fills its background, so
/// equal inputs give byte-identical files.
pub(crate) fn render(
    w: u32,
    h: u32,
    bitmap: &BitmapDrawing<'_>,
    svg: &SvgDrawing<'_>,
) -> Result<Figure, PlotError> {
    register_fonts()?;
    let mut rgb = vec![255u8; w as usize * h as usize * 3];
    {
        let backend = BitMapBackend::<RGBPixel>::with_buffer_and_format(&mut rgb, (w, h))
            .map_err(|e| PlotError::Backend(e.to_string()))?;
        let root = backend.into_drawing_area();
        bitmap(&root)?;
        root.present().map_err(backend_error)?;
    }
    let png = encode_png(&rgb, w, h)?;
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (w, h)).into_drawing_area();
        svg(&root)?;
        root.present().map_err(backend_error)?;
    }
    Ok(Figure { png, svg: text })
}

// ---------------------------------------------------------------------------------------------
// Fonts and encoding

static FONT_INIT: Once = Once::new();
static FONT_OK: AtomicBool = AtomicBool::new(false);

/// Registers DejaVu Sans (regular, bold, oblique) as plotters' `sans-serif`, once per process.
pub(crate) fn register_fonts() -> Result<(), PlotError> {
    FONT_INIT.call_once(|| {
        let ok = register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular()).is_ok()
            && register_font("sans-serif", FontStyle::Bold, dejavu::sans::bold()).is_ok()
            && register_font("sans-serif", FontStyle::Italic, dejavu::sans::oblique()).is_ok()
            && register_font("sans-serif", FontStyle::Oblique, dejavu::sans::oblique()).is_ok();
        FONT_OK.store(ok, Ordering::Release);
    });
    if FONT_OK.load(Ordering::Acquire) {
        Ok(())
    } else {
        Err(PlotError::Font)
    }
}

pub(crate) fn encode_png(rgb: &[u8], w: u32, h: u32) -> Result<Vec<u8>, PlotError> {
    use image::ImageEncoder;
    if rgb.len() != w as usize * h as usize * 3 {
        return Err(PlotError::Encode(format!(
            "buffer holds {} bytes for {w}x{h} px",
            rgb.len()
        )));
    }
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(rgb, w, h, image::ColorType::Rgb8)
        .map_err(|e| PlotError::Encode(e.to_string()))?;
    Ok(png)
}

/// A drawing backend's error as a [`PlotError`].
pub(crate) fn backend_error<E: std::fmt::Display>(e: E) -> PlotError {
    PlotError::Backend(e.to_string())
}

// ---------------------------------------------------------------------------------------------
// Colours

/// Colour-blind-aware categorical palette (Okabe-Ito order), one colour per series.
pub(crate) const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 114, 178),   // blue
    RGBColor(213, 94, 0),    // vermillion
    RGBColor(0, 158, 115),   // bluish green
    RGBColor(204, 121, 167), // reddish purple
    RGBColor(230, 159, 0),   // orange
    RGBColor(86, 180, 233),  // sky blue
    RGBColor(120, 94, 240),  // violet
    RGBColor(140, 86, 75),   // brown
];

/// The finite range of values seen so far.
#[derive(Default)]
pub(crate) struct Extent(Option<(f64, f64)>);

impl Extent {
    /// Widens the range to `v` when it is finite.
    pub(crate) fn add(&mut self, v: f64) {
        if v.is_finite() {
            self.0 = Some(match self.0 {
                Some((lo, hi)) => (lo.min(v), hi.max(v)),
                None => (v, v),
            });
        }
    }

    /// The range, if any finite value was seen.
    pub(crate) fn get(&self) -> Option<(f64, f64)> {
        self.0
    }
}

// ---------------------------------------------------------------------------------------------
// Axes: a linear axis with its own tick positions, so ticks are chosen here (nice steps) and
// never from a degenerate range.

/// A linear axis from `lo` to `hi` with its major (labelled) and minor tick positions.
#[derive(Clone, Debug)]
pub(crate) struct Axis {
    pub(crate) lo: f64,
    pub(crate) hi: f64,
    pub(crate) major: Vec<f64>,
    pub(crate) minor: Vec<f64>,
    /// Decimals that print every major tick exactly.
    pub(crate) decimals: usize,
}

impl Axis {
    /// About `target` major ticks at a nice step over `[lo, hi]`, minor ticks between.
    pub(crate) fn with_ticks(lo: f64, hi: f64, target: usize) -> Axis {
        let step = nice_step((hi - lo) / target as f64);
        let minor_step = step / if is_two(step) { 4.0 } else { 5.0 };
        let decimals = (-step.log10().floor()).clamp(0.0, 12.0) as usize;
        Axis {
            lo,
            hi,
            major: ticks(lo, hi, step),
            minor: ticks(lo, hi, minor_step),
            decimals,
        }
    }

    /// A tick label: the axis's decimals (scientific when huge or tiny), no `-0`, a
    /// typographic minus.
    pub(crate) fn label(&self, v: f64) -> String {
        let s = if v.abs() >= 1e7 || (v != 0.0 && v.abs() < 1e-5 && self.decimals > 5) {
            format!("{v:.3e}")
        } else {
            format!("{:.*}", self.decimals, v)
        };
        // Avoid "-0" and use a typographic minus.
        let s = if s
            .trim_start_matches('-')
            .chars()
            .all(|c| c == '0' || c == '.')
        {
            s.trim_start_matches('-').to_string()
        } else {
            s
        };
        s.replace('-', "−")
    }
}

/// `(lo, hi)` with a positive span that survives rounding.
pub(crate) fn widen(lo: f64, hi: f64, half: f64) -> (f64, f64) {
    let min_span = (lo.abs().max(hi.abs()) * 1e-9).max(f64::MIN_POSITIVE);
    if hi - lo > min_span {
        (lo, hi)
    } else {
        let h = half.max(lo.abs() * 0.01);
        (lo - h, hi + h)
    }
}

/// 1, 2 or 5 times a power of ten, at least `raw`.
pub(crate) fn nice_step(raw: f64) -> f64 {
    if !(raw.is_finite() && raw > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let mult = if norm <= 1.0 {
        1.0
    } else if norm <= 2.0 {
        2.0
    } else if norm <= 5.0 {
        5.0
    } else {
        10.0
    };
    mult * mag
}

fn is_two(step: f64) -> bool {
    let mag = 10f64.powf(step.log10().floor());
    ((step / mag) - 2.0).abs() < 1e-9
}

/// Multiples of `step` within `[lo, hi]` (at most 200).
pub(crate) fn ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    if !(step.is_finite() && step > 0.0) {
        return Vec::new();
    }
    let first = (lo / step).ceil();
    let tol = step * 1e-6;
    (0..200)
        .map(|k| (first + k as f64) * step)
        .take_while(|v| *v <= hi + tol)
        .filter(|v| *v >= lo - tol)
        .collect()
}

impl Ranged for Axis {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let t = (value - self.lo) / (self.hi - self.lo);
        let px = limit.0 as f64 + t * (limit.1 - limit.0) as f64;
        if px.is_finite() {
            px.round() as i32
        } else {
            limit.0
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.major.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.lo..self.hi
    }
}

// ---------------------------------------------------------------------------------------------
// Metrics and text

/// Pixel sizes derived from the figure size.
pub(crate) struct Metrics {
    /// Pixels per unit of size.
    pub(crate) u: f64,
}

impl Metrics {
    /// `v` units in whole pixels, at least 1.
    pub(crate) fn px(&self, v: f64) -> i32 {
        (v * self.u).round().max(1.0) as i32
    }

    /// Width of a data line: at least 2 px so curves stay solid on small figures.
    pub(crate) fn line(&self) -> u32 {
        self.px(1.8).max(2) as u32
    }

    /// Font size in pixels, an even integer: plotters' ab_glyph renderer places each glyph at
    /// `size / 2` truncated, so odd or fractional sizes shift some glyphs (e.g. `.`) by a pixel.
    pub(crate) fn font(&self, v: f64) -> f64 {
        ((v * self.u / 2.0).round() * 2.0).max(8.0)
    }
}

/// A `sans-serif` text style.
pub(crate) fn text_style<'a>(
    size: f64,
    style: FontStyle,
    color: RGBColor,
    pos: Pos,
) -> TextStyle<'a> {
    TextStyle {
        font: ("sans-serif", size, style).into_font(),
        color: color.to_backend_color(),
        pos,
    }
}
