//! Tests of the FRF figures: sizes and formats, determinism, panels, errors naming what is
//! valid, non-finite values, crowded and small figures, axis ticks and decades.

use super::*;
use crate::core::{Component, DofId};
use faer::Mat;

fn dof(node: u64) -> DofId {
    DofId::new(node, Component::Uz)
}

fn pair(r: u64, e: u64) -> FrfPair {
    FrfPair {
        response: dof(r),
        excitation: dof(e),
    }
}

/// Receptances of single-DOF oscillators `1/(k − ω²m + iωc)` scaled per FRF.
fn sdof_set(pairs: &[FrfPair], fn_hz: &[f64], zeta: f64, scale: &[f64]) -> FrfSet {
    let freqs: Vec<f64> = (0..=400).map(|k| 1.0 + k as f64 * 0.1).collect();
    let values = Mat::from_fn(freqs.len(), pairs.len(), |k, j| {
        let w = 2.0 * std::f64::consts::PI * freqs[k];
        let wn = 2.0 * std::f64::consts::PI * fn_hz[j];
        let (m, kk) = (1.0, wn * wn);
        let c = 2.0 * zeta * wn * m;
        let z = c64::new(kk - w * w * m, w * c);
        c64::new(scale[j], 0.0) / z
    });
    FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: freqs,
        pairs: pairs.to_vec(),
        values,
    }
}

fn example() -> (FrfSet, FrfSet, FrfCorrelation) {
    let pairs = [pair(1, 1), pair(2, 1)];
    let mut measured = sdof_set(&pairs, &[12.0, 27.0], 0.02, &[1.0, -0.6]);
    // Deterministic ripple standing in for measurement noise.
    for k in 0..measured.freqs_hz.len() {
        for j in 0..pairs.len() {
            let e = 1.0 + 0.06 * ((k * 7 + j * 3) as f64).sin();
            measured.values[(k, j)] *= e;
        }
    }
    let predicted = sdof_set(&pairs, &[12.6, 26.0], 0.025, &[1.0, -0.6]);
    let corr = crate::correlation::correlate(&measured, &predicted).unwrap();
    (measured, predicted, corr)
}

fn png_size(png: &[u8]) -> (u32, u32) {
    let img = image::load_from_memory_with_format(png, image::ImageFormat::Png).unwrap();
    (img.width(), img.height())
}

#[test]
fn renders_png_of_requested_size_and_svg() {
    let (m, p, c) = example();
    let opts = FrfPlotOptions {
        width_px: 1000,
        height_px: 760,
        ..FrfPlotOptions::default()
    };
    let fig = frf_overlay(&m, Some(&p), Some(&c), &opts).unwrap();
    assert_eq!(&fig.png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(png_size(&fig.png), (1000, 760));
    assert!(fig.svg.contains("<svg"));
    assert!(fig.svg.contains("H 1:uz/1:uz"));
    assert!(fig.svg.contains("Frequency (Hz)"));
    assert!(fig.svg.contains("dB re 1 m/N"));
}

#[test]
fn output_is_deterministic() {
    let (m, p, c) = example();
    let opts = FrfPlotOptions::default();
    let a = frf_overlay(&m, Some(&p), Some(&c), &opts).unwrap();
    let b = frf_overlay(&m, Some(&p), Some(&c), &opts).unwrap();
    assert!(a.png == b.png, "PNG bytes differ between runs");
    assert_eq!(a.svg, b.svg);
}

#[test]
fn measured_only_renders_two_panels() {
    let (m, _, _) = example();
    let opts = FrfPlotOptions {
        title: "Measurement".to_string(),
        ..FrfPlotOptions::default()
    };
    let fig = frf_overlay(&m, None, None, &opts).unwrap();
    assert_eq!(png_size(&fig.png), (1200, 900));
    assert!(!fig.svg.contains("Correlation"));
    assert!(!fig.svg.contains("predicted"));
}

#[test]
fn unknown_pair_is_an_error_naming_the_valid_ones() {
    let (m, p, c) = example();
    let opts = FrfPlotOptions {
        pairs: Some(vec![pair(1, 1), pair(9, 1)]),
        ..FrfPlotOptions::default()
    };
    let err = frf_overlay(&m, Some(&p), Some(&c), &opts).unwrap_err();
    assert!(matches!(err, PlotError::UnknownPair { .. }), "{err}");
    let msg = err.to_string();
    assert!(
        msg.contains("9:uz/1:uz") && msg.contains("1:uz/1:uz, 2:uz/1:uz"),
        "{msg}"
    );
}

#[test]
fn empty_set_is_an_error() {
    let empty = FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: Vec::new(),
        pairs: Vec::new(),
        values: Mat::zeros(0, 0),
    };
    let err = frf_overlay(&empty, None, None, &FrfPlotOptions::default()).unwrap_err();
    assert_eq!(err, PlotError::Empty { pairs: 0, lines: 0 });
    let no_lines = FrfSet {
        pairs: vec![pair(1, 1)],
        values: Mat::zeros(0, 1),
        ..empty.clone()
    };
    let err = frf_overlay(&no_lines, None, None, &FrfPlotOptions::default()).unwrap_err();
    assert_eq!(err, PlotError::Empty { pairs: 1, lines: 0 });
}

#[test]
fn invalid_requests_are_errors() {
    let (m, p, c) = example();
    let run = |opts: FrfPlotOptions| frf_overlay(&m, Some(&p), Some(&c), &opts).unwrap_err();
    let d = FrfPlotOptions::default;
    assert!(matches!(
        run(FrfPlotOptions {
            pairs: Some(vec![]),
            ..d()
        }),
        PlotError::NoneSelected { .. }
    ));
    assert!(matches!(
        run(FrfPlotOptions {
            pairs: Some(vec![pair(1, 1), pair(1, 1)]),
            ..d()
        }),
        PlotError::DuplicatePair { .. }
    ));
    assert!(matches!(
        run(FrfPlotOptions {
            pairs: Some(vec![pair(1, 1), pair(2, 1)]),
            max_frfs: 1,
            ..d()
        }),
        PlotError::TooMany { .. }
    ));
    assert!(matches!(
        run(FrfPlotOptions { max_frfs: 0, ..d() }),
        PlotError::MaxFrfs { .. }
    ));
    assert!(matches!(
        run(FrfPlotOptions {
            width_px: 10,
            ..d()
        }),
        PlotError::Size { .. }
    ));
    let mut bad = m.clone();
    bad.freqs_hz.pop();
    assert!(matches!(
        frf_overlay(&bad, None, None, &d()).unwrap_err(),
        PlotError::Shape {
            which: "measured",
            ..
        }
    ));
    let mut other = p.clone();
    other.quantity = Quantity::Mobility;
    assert!(matches!(
        frf_overlay(&m, Some(&other), None, &d()).unwrap_err(),
        PlotError::Quantity { .. }
    ));
    let partial = FrfSet {
        pairs: vec![pair(1, 1)],
        values: Mat::from_fn(p.freqs_hz.len(), 1, |k, _| p.values[(k, 0)]),
        ..p.clone()
    };
    assert!(matches!(
        frf_overlay(&m, Some(&partial), None, &d()).unwrap_err(),
        PlotError::MissingPrediction { .. }
    ));
    let mut short = c.clone();
    short.chi_a.pop();
    assert!(matches!(
        frf_overlay(&m, None, Some(&short), &d()).unwrap_err(),
        PlotError::CorrelationShape { .. }
    ));
}

#[test]
fn non_finite_values_are_skipped_not_fatal() {
    let (mut m, p, mut c) = example();
    for k in 0..m.freqs_hz.len() {
        let v = match k % 5 {
            0 => c64::new(0.0, 0.0),
            1 => c64::new(f64::NAN, 1.0),
            2 => c64::new(f64::INFINITY, 0.0),
            _ => continue,
        };
        m.values[(k, 0)] = v;
    }
    m.freqs_hz[3] = f64::NAN;
    c.chi_s[4] = f64::NAN;
    c.chi_a[5] = 7.0;
    let fig = frf_overlay(&m, Some(&p), Some(&c), &FrfPlotOptions::default()).unwrap();
    assert_eq!(png_size(&fig.png), (1200, 900));

    // Nothing finite at all: still a figure, with a note instead of curves.
    let zeros = FrfSet {
        values: Mat::zeros(m.freqs_hz.len(), m.pairs.len()),
        ..m.clone()
    };
    let fig = frf_overlay(&zeros, None, None, &FrfPlotOptions::default()).unwrap();
    assert!(fig.svg.contains("no finite amplitude"));

    // A single line, and frequencies that are all NaN.
    let one = FrfSet {
        freqs_hz: vec![10.0],
        values: Mat::from_fn(1, 2, |_, j| c64::new(1.0 + j as f64, 0.0)),
        ..m.clone()
    };
    frf_overlay(&one, None, None, &FrfPlotOptions::default()).unwrap();
    let nan = FrfSet {
        freqs_hz: vec![f64::NAN],
        ..one.clone()
    };
    assert_eq!(
        frf_overlay(&nan, None, None, &FrfPlotOptions::default()).unwrap_err(),
        PlotError::NoFrequencies
    );
    let wide = FrfSet {
        freqs_hz: vec![-1e308, 1e308],
        values: Mat::from_fn(2, 2, |_, _| c64::new(1.0, 0.0)),
        ..m.clone()
    };
    assert!(matches!(
        frf_overlay(&wide, None, None, &FrfPlotOptions::default()).unwrap_err(),
        PlotError::FrequencySpan { .. }
    ));
    // Extreme but finite magnitudes.
    let extreme = FrfSet {
        values: Mat::from_fn(2, 2, |k, _| {
            c64::new(if k == 0 { 1e-320 } else { 1e300 }, 0.0)
        }),
        freqs_hz: vec![1e12, 1e12 + 1e-3],
        ..wide.clone()
    };
    frf_overlay(&extreme, None, None, &FrfPlotOptions::default()).unwrap();
}

#[test]
fn small_odd_and_crowded_figures_render() {
    let pairs: Vec<FrfPair> = (1..=8).map(|r| pair(r, 1)).collect();
    let fns: Vec<f64> = (0..8).map(|i| 5.0 + 4.0 * i as f64).collect();
    let m = sdof_set(&pairs, &fns, 0.02, &[1.0; 8]);
    let p = sdof_set(&pairs, &fns, 0.03, &[1.1; 8]);
    let c = crate::correlation::correlate(&m, &p).unwrap();
    for (w, h) in [(400, 400), (2400, 400), (400, 1600), (1600, 1200)] {
        let opts = FrfPlotOptions {
            title: "A title far too long for a small figure, it runs off both edges".into(),
            width_px: w,
            height_px: h,
            max_frfs: MAX_FRFS,
            pairs: None,
        };
        let fig = frf_overlay(&m, Some(&p), Some(&c), &opts).unwrap();
        assert_eq!(png_size(&fig.png), (w, h));
    }
}

#[test]
fn ticks_are_nice() {
    let a = Axis::with_ticks(1.0, 41.0, 8);
    assert_eq!(a.major, vec![5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 35.0, 40.0]);
    assert_eq!(a.label(-0.0), "0");
    assert_eq!(a.label(-20.0), "−20");
    let d = Axis::decibel(-143.2, -41.0);
    assert!(d.lo <= -143.2 - 2.0 && d.hi >= -41.0 + 2.0);
    assert!(d.major.iter().all(|v| v.fract() == 0.0));
}

/// Writes `/tmp/frf_plot_example.png` and `.svg` for a visual check:
/// `cargo test --release frf_plot::tests::write_example -- --ignored`.
#[test]
#[ignore = "writes example figures to /tmp for a visual check; run on demand"]
fn write_example() {
    let (m, p, c) = example();
    let opts = FrfPlotOptions {
        title: "Two-DOF check: measured vs updated model".to_string(),
        ..FrfPlotOptions::default()
    };
    let fig = frf_overlay(&m, Some(&p), Some(&c), &opts).unwrap();
    std::fs::write("/tmp/frf_plot_example.png", &fig.png).unwrap();
    std::fs::write("/tmp/frf_plot_example.svg", &fig.svg).unwrap();
    let fig = frf_overlay(&m, None, None, &opts).unwrap();
    std::fs::write("/tmp/frf_plot_example_measured.png", &fig.png).unwrap();
    let panels = SmallMultiplesOptions {
        title: "Two-DOF check: one panel per FRF".to_string(),
        pairs: None,
    };
    let fig = frf_small_multiples(&m, Some(&p), Some(&c), &panels).unwrap();
    std::fs::write("/tmp/frf_plot_example_panels.png", &fig.png).unwrap();
}

/// One framed panel per FRF, each caption with its FRAC, the mean χ under the title; the
/// figure is valid SVG and PNG with a row of two panels; a set without prediction draws
/// only the measured curves.
#[test]
fn small_multiples_draw_one_panel_per_frf() {
    use crate::report::mac_plot::check::{count_with, svg_elements};
    let (measured, predicted, corr) = example();
    let opts = SmallMultiplesOptions {
        title: "FRFs".into(),
        pairs: None,
    };
    let fig = frf_small_multiples(&measured, Some(&predicted), Some(&corr), &opts).unwrap();
    assert_eq!(
        fig,
        frf_small_multiples(&measured, Some(&predicted), Some(&corr), &opts).unwrap()
    );
    svg_elements(&fig.svg).unwrap();
    assert_eq!(count_with(&fig.svg, "rect", "stroke=\"#1E1E1E\""), 2);
    for (k, p) in measured.pairs.iter().enumerate() {
        let caption = format!("H {} · FRAC {:.2}", pair_name(p), corr.frac[k]);
        assert_eq!(fig.svg.matches(&caption).count(), 1, "{caption}");
    }
    assert!(fig.svg.contains("mean χs ="));
    assert!(fig.svg.contains("|H| (m/N)") && fig.svg.contains("Frequency (Hz)"));
    // Predicted curves in the second palette colour, one per panel.
    assert_eq!(count_with(&fig.svg, "polyline", "stroke=\"#D55E00\""), 2);
    assert_eq!(
        png_size(&fig.png),
        (2 * SM_PANEL.0 + 24, SM_HEAD + SM_PANEL.1 + 8)
    );
    let alone = frf_small_multiples(
        &measured,
        None,
        None,
        &SmallMultiplesOptions {
            title: "FRFs".into(),
            pairs: Some(vec![pair(2, 1)]),
        },
    )
    .unwrap();
    assert_eq!(count_with(&alone.svg, "rect", "stroke=\"#1E1E1E\""), 1);
    assert_eq!(count_with(&alone.svg, "polyline", "stroke=\"#D55E00\""), 0);
    let unknown = SmallMultiplesOptions {
        title: "FRFs".into(),
        pairs: Some(vec![pair(9, 1)]),
    };
    assert!(matches!(
        frf_small_multiples(&measured, None, None, &unknown),
        Err(PlotError::UnknownPair { .. })
    ));
}

/// Log axes snap to whole decades and label them readably.
#[test]
fn log_axes_use_decades() {
    let a = Axis::log_decades(0.3, 2.2, 4, true);
    assert_eq!((a.lo, a.hi), (0.0, 3.0));
    assert_eq!(a.major, [0.0, 1.0, 2.0, 3.0]);
    assert_eq!(a.minor.len(), 28);
    assert_eq!(Axis::log_decades(-9.0, 1.0, 4, true).major.len(), 4);
    // Not snapped: the data extent, with the decades inside labelled.
    let b = Axis::log_decades(0.0, 40f64.log10(), 4, false);
    assert_eq!((b.lo, b.hi), (0.0, 40f64.log10()));
    assert_eq!(b.major, [0.0, 1.0]);
    // Less than two decades inside: 1, 2 and 5 times a decade.
    let c = Axis::log_decades(0.5, 1.5, 4, false);
    let labels: Vec<String> = c.major.iter().map(|v| decade_label(*v)).collect();
    assert_eq!(labels, ["5", "10", "20"]);
    assert_eq!(decade_label(2.0), "100");
    assert_eq!(decade_label(-2.0), "0.01");
    assert_eq!(decade_label(-7.0), "1e−7");
    assert_eq!(decade_label(-7.0 + 5f64.log10()), "5e−7");
}
