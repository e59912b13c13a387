use super::lex::{parse_real, split_numbers};
use super::units::{POUND_FORCE, STANDARD_GRAVITY};
use super::*;
use crate::core::{Component, DofId};
use crate::frf::{FrfPair, FrfSet, Quantity, frequency_lines};
use faer::{Mat, c64};
use proptest::prelude::*;
use std::f64::consts::PI;

/// A dataset 58 in the published layout: FRF (type 4), response 3:+Z, reference 1:+Z,
/// complex double, even abscissa from 10 Hz by 0.5 Hz, acceleration over force in m/s²/N.
const HAND_58: &str = concat!(
    "    -1\n",
    "    58\n",
    "H 3:uz / 1:uz accelerance\n",
    "NONE\n",
    "18-Apr-16 13:49:58\n",
    "NONE\n",
    "NONE\n",
    "    4         1    0         0 NONE               3   3 NONE               1   3\n",
    "         6         3         1  1.00000E+01  5.00000E-01  0.00000E+00\n",
    "        18    0    0    0 Frequency            Hz                  \n",
    "        12    1    0    0 Acceleration         m/s^2               \n",
    "        13    0    1    0 Force                N                   \n",
    "         0    0    0    0 NONE                 NONE                \n",
    "   1.00000000000E+00  -2.00000000000E+00   3.50000000000E-01   4.00000000000E+00\n",
    "  -5.00000000000E-01   6.25000000000E-02\n",
    "    -1\n",
);
const HAND_VALUES: [(f64, f64); 3] = [(1.0, -2.0), (0.35, 4.0), (-0.5, 0.0625)];
const R6: &str = "    4         1    0         0 NONE               3   3 NONE               1   3";
const R9: &str = "        12    1    0    0 Acceleration         m/s^2               ";

fn parse(s: &str) -> Result<UffFile, UffError> {
    parse_uff(s.as_bytes(), "test.uff")
}

fn field_error(e: &UffError) -> (usize, u32, &'static str, String) {
    match e {
        UffError::Field {
            line,
            dataset,
            record,
            field,
            ..
        } => (*line, *dataset, *record, field.clone()),
        other => panic!("expected a field error, got {other}"),
    }
}

#[test]
fn fortran_reals_and_touching_fields_are_read() {
    assert_eq!(parse_real(" 1.5E+02 "), Some(150.0));
    assert_eq!(parse_real("1.5D+02"), Some(150.0));
    assert_eq!(parse_real("0.15+003"), Some(150.0));
    assert_eq!(parse_real("-0.15-002"), Some(-0.0015));
    assert_eq!(parse_real("1."), Some(1.0));
    assert!(parse_real("NaN").is_some_and(f64::is_nan));
    assert_eq!(parse_real("-Inf"), Some(f64::NEG_INFINITY));
    assert_eq!(parse_real("1.0x"), None);
    assert_eq!(parse_real("é-1"), None);
    assert_eq!(
        split_numbers("1.0E+00-2.0E+00+3.5E-01"),
        vec!["1.0E+00", "-2.0E+00", "+3.5E-01"]
    );
    assert_eq!(
        split_numbers("0.123+100-0.5E+00"),
        vec!["0.123+100", "-0.5E+00"]
    );
    assert_eq!(split_numbers("-1.5"), vec!["-1.5"]);
}

#[test]
fn hand_written_dataset_58_reads_to_known_values() {
    let f = parse(HAND_58).unwrap();
    assert_eq!(f.frfs.len(), 1);
    let r = &f.frfs[0];
    assert_eq!(r.line, 2);
    assert_eq!(r.id_lines[0], "H 3:uz / 1:uz accelerance");
    assert_eq!(r.id_lines[2], "18-Apr-16 13:49:58");
    assert_eq!(r.response, "3:uz".parse().unwrap());
    assert_eq!(r.reference, "1:uz".parse().unwrap());
    assert_eq!((r.response_direction, r.reference_direction), (3, 3));
    assert!(!r.sign_flipped);
    assert_eq!(r.function_id, 1);
    assert_eq!(r.ordinate, OrdinateType::ComplexDouble);
    assert_eq!(r.quantity, Quantity::Accelerance);
    assert_eq!(
        r.abscissa,
        Abscissa::Even {
            start_hz: 10.0,
            step_hz: 0.5
        }
    );
    assert_eq!(r.freqs_hz, vec![10.0, 10.5, 11.0]);
    let want: Vec<c64> = HAND_VALUES.iter().map(|&(a, b)| c64::new(a, b)).collect();
    assert_eq!(r.values, want);
    assert!(r.conversions.is_empty(), "{:?}", r.conversions);
    assert!(
        f.conversions.is_empty() && f.warnings.is_empty(),
        "{:?}",
        f.warnings
    );
    let set = to_frf_set(&f.frfs).unwrap();
    assert_eq!(set.values[(1, 0)], c64::new(0.35, 4.0));
}

#[test]
fn crlf_line_ends_and_free_format_fields_read_alike() {
    let crlf = HAND_58.replace('\n', "\r\n");
    assert_eq!(parse(&crlf).unwrap().frfs, parse(HAND_58).unwrap().frfs);
    // Record 7 and the data written free-format, the data with touching fields.
    let free = HAND_58
        .replace(
            "         6         3         1  1.00000E+01  5.00000E-01  0.00000E+00",
            "6 3 1 10.0 0.5 0.0",
        )
        .replace(
            "   1.00000000000E+00  -2.00000000000E+00   3.50000000000E-01   4.00000000000E+00",
            "1.0E+00-2.0E+00 0.35 4.0D0",
        );
    assert_eq!(
        parse(&free).unwrap().frfs[0].values,
        parse(HAND_58).unwrap().frfs[0].values
    );
}

#[test]
fn a_negative_direction_flips_the_sign_and_says_so() {
    let neg = HAND_58.replace(
        R6,
        "    4         1    0         0 NONE               3  -3 NONE               1   3",
    );
    let f = parse(&neg).unwrap();
    let r = &f.frfs[0];
    assert_eq!(r.response, "3:uz".parse().unwrap());
    assert_eq!(r.response_direction, -3);
    assert!(r.sign_flipped);
    for (v, (a, b)) in r.values.iter().zip(HAND_VALUES) {
        assert_eq!(*v, c64::new(-a, -b));
    }
    assert!(
        f.conversions
            .iter()
            .any(|c| c.contains("negated") && c.contains("test.uff:2")),
        "{:?}",
        f.conversions
    );
    // Both negative: the sense of both is reversed, the FRF is unchanged.
    let both = HAND_58.replace(
        R6,
        "    4         1    0         0 NONE               3  -3 NONE               1  -3",
    );
    let r = &parse(&both).unwrap().frfs[0];
    assert!(!r.sign_flipped);
    assert_eq!(r.values[0], c64::new(1.0, -2.0));
}

#[test]
fn unit_labels_convert_to_si_and_are_recorded() {
    // mm/N displacement → m/N receptance.
    let mm = HAND_58.replace(
        R9,
        "         8    1    0    0 Displacement         mm                  ",
    );
    let f = parse(&mm).unwrap();
    let r = &f.frfs[0];
    assert_eq!(r.quantity, Quantity::Receptance);
    assert!((r.values[0] - c64::new(1e-3, -2e-3)).norm() < 1e-18);
    assert!(
        r.conversions
            .iter()
            .any(|c| c.contains("m/N") && c.contains("`mm`") && c.contains("1e-3")),
        "{:?}",
        r.conversions
    );
    assert_eq!(f.conversions, r.conversions);
    // g/lbf in one label, with a rad/s abscissa.
    let g = HAND_58
        .replace(
            R9,
            "        12    1    0    0 Acceleration         g/lbf               ",
        )
        .replace(
            "        13    0    1    0 Force                N                   ",
            "        13    0    1    0 Force                NONE                ",
        )
        .replace(
            "        18    0    0    0 Frequency            Hz                  ",
            "        18    0    0    0 Frequency            rad/s               ",
        );
    let r = &parse(&g).unwrap().frfs[0];
    let k = STANDARD_GRAVITY / POUND_FORCE;
    assert!((r.values[0].re - k).abs() < 1e-15 && (r.values[0].im + 2.0 * k).abs() < 1e-15);
    assert!((r.freqs_hz[0] - 10.0 / (2.0 * PI)).abs() < 1e-14);
    assert_eq!(r.conversions.len(), 2, "{:?}", r.conversions);
    // Velocity in mm/s with the type unknown (0): the label decides.
    let v = HAND_58.replace(
        R9,
        "         0    0    0    0 NONE                 mm/s                ",
    );
    let r = &parse(&v).unwrap().frfs[0];
    assert_eq!(r.quantity, Quantity::Mobility);
    assert!((r.values[2].re + 0.5e-3).abs() < 1e-18);
}

#[test]
fn dataset_164_converts_unlabelled_data_and_nodes() {
    let units = concat!(
        "    -1\n",
        "   164\n",
        "         5mm (milli newton)               2\n",
        "  1.00000000000000000D+03  1.00000000000000000D+03  1.00000000000000000D+00\n",
        "  2.73150000000000000D+02\n",
        "    -1\n",
        "    -1\n",
        "    15\n",
        "         7         0         0         8  1.00000E+00  2.00000E+00 -3.50000E+00\n",
        "    -1\n",
    );
    let unlabelled = HAND_58
        .replace(
            R9,
            "        12    1    0    0 NONE                 NONE                ",
        )
        .replace(
            "        13    0    1    0 Force                N                   ",
            "        13    0    1    0 NONE                 NONE                ",
        );
    let f = parse(&format!("{units}{unlabelled}")).unwrap();
    assert_eq!(f.units.as_ref().map(|u| u.code), Some(5));
    assert_eq!(f.nodes, vec![(7, [1e-3, 2e-3, -3.5e-3])]);
    assert_eq!(f.node_systems, vec![[0, 0, 8]]);
    // mm/s² per mN = 1e-3 m/s² per 1e-3 N: a factor of one, nothing to convert.
    let r = &f.frfs[0];
    assert_eq!(r.values[0], c64::new(1.0, -2.0));
    assert!(r.conversions.is_empty(), "{:?}", r.conversions);
    assert!(
        f.conversions.iter().any(|c| c.contains("coordinates")),
        "{:?}",
        f.conversions
    );
    // Without labels and without 164: SI, with one warning for all such records.
    let other = unlabelled.replace(
        R6,
        "    4         1    0         0 NONE               2   3 NONE               1   3",
    );
    let f = parse(&format!("{unlabelled}{other}")).unwrap();
    assert_eq!(f.frfs[1].values[0], c64::new(1.0, -2.0));
    assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
    assert!(f.warnings[0].contains("taken as SI"), "{:?}", f.warnings);
}

#[test]
fn dataset_2411_15_and_2412_are_read() {
    let text = concat!(
        "    -1\n",
        "  2411\n",
        "       101         1         1        11\n",
        "   1.5000000000000000E+00  -2.5000000000000000E-01   1.0000000000000000E-03\n",
        "       102         1         1        11\n",
        "   0.1234567890123456D+01   0.0000000000000000D+00  -7.0000000000000000D+02\n",
        "    -1\n",
        "    -1\n",
        "    15\n",
        "         7         0         0         8  1.00000E+00  2.00000E+00 -3.50000E+00\n",
        "    -1\n",
        "    -1\n",
        "  2412\n",
        "         1        94         1         1         7         4\n",
        "       101       102         7       101\n",
        "         2        21         2         1         7         2\n",
        "         0         1         1\n",
        "       101       102\n",
        "         3       116         1         1         7         9\n",
        "         1         2         3         4         5         6         7         8\n",
        "         9\n",
        "    -1\n",
        "    -1\n",
        "   151\n",
        "plate.mf1\n",
        "    -1\n",
    );
    let f = parse(text).unwrap();
    assert_eq!(
        f.nodes,
        vec![
            (101, [1.5, -0.25, 1e-3]),
            (102, [1.234567890123456, 0.0, -700.0]),
            (7, [1.0, 2.0, -3.5])
        ]
    );
    assert_eq!(f.node_systems[0], [1, 1, 11]);
    assert_eq!(f.elements.len(), 3);
    assert_eq!(f.elements[0].nodes, vec![101, 102, 7, 101]);
    assert_eq!(f.elements[0].beam, None);
    assert_eq!(f.elements[1].descriptor, 21);
    assert_eq!(
        f.elements[1].beam,
        Some(UffBeam {
            orientation_node: 0,
            fore_section: 1,
            aft_section: 1
        })
    );
    assert_eq!(f.elements[1].nodes, vec![101, 102]);
    assert_eq!(f.elements[2].nodes, (1..=9).collect::<Vec<u64>>());
    assert_eq!(f.elements[2].line, 19);
    assert!(f.skipped.is_empty(), "{:?}", f.skipped);
    assert_eq!(
        f.header.as_ref().map(|h| h.model.as_str()),
        Some("plate.mf1")
    );
    // System 1 is not defined in the file: taken as global, and said so.
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("2 node(s) name definition coordinate system 1")),
        "{:?}",
        f.warnings
    );
    // Written nodes read back exactly.
    let nodes = vec![(5, [0.1, -1.0 / 3.0, 2e-300]), (6, [1e5, PI, -0.0])];
    let back = parse_uff(&write_uff2411(&nodes), "n.uff").unwrap();
    assert_eq!(back.nodes, nodes);
    // A node defined twice is an error naming both lines.
    let twice = format!(
        "{}{}",
        &text[..text.find("    -1\n  2412").unwrap()],
        "    -1\n    15\n       101         0         0         8  1.00000E+00  2.00000E+00 -3.50000E+00\n    -1\n"
    );
    let e = parse(&twice).unwrap_err();
    assert!(
        matches!(
            e,
            UffError::DuplicateNode {
                node: 101,
                first: 3,
                second: 14,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn node_labels_wider_than_their_field_are_not_misread() {
    let wide = HAND_58.replace(
        R6,
        "    4         1    0         0 NONE      12345678901   3 NONE               1   3",
    );
    assert_eq!(
        parse(&wide).unwrap().frfs[0].response,
        DofId::new(12_345_678_901, Component::Uz)
    );
    let set = FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: vec![1.0, 2.0],
        pairs: vec![FrfPair {
            response: DofId::new(98_765_432_101, Component::Rx),
            excitation: DofId::new(12_345_678_901, Component::Uy),
        }],
        values: Mat::from_fn(2, 1, |i, _| c64::new(i as f64, 1.0)),
    };
    let back = to_frf_set(&parse_uff(&write_uff58(&set, false), "w.uff").unwrap().frfs).unwrap();
    assert_eq!(back.pairs, set.pairs);
    // The pyuff sample layout: an entity name with a blank.
    let named = HAND_58.replace(
        R6,
        "    4         0    0         0 Mic 01             3   3 NONE               1   3",
    );
    assert_eq!(
        parse(&named).unwrap().frfs[0].response,
        DofId::new(3, Component::Uz)
    );
}

#[test]
fn other_function_types_are_skipped_with_a_warning() {
    let coh = HAND_58.replace(
        R6,
        "    6         1    0         0 NONE               3   3 NONE               1   3",
    );
    let f = parse(&format!("{coh}{HAND_58}")).unwrap();
    assert_eq!(f.frfs.len(), 1);
    assert_eq!(f.frfs[0].line, 18);
    assert_eq!(f.skipped, vec![(58, 1)]);
    assert!(
        f.warnings.iter().any(|w| w.contains("type 6 (coherence)")),
        "{:?}",
        f.warnings
    );
}

#[test]
fn bad_fields_are_named_with_line_record_and_valid_values() {
    let bad = HAND_58.replace(
        "         6         3         1  1.00000E+01",
        "         3         3         1  1.00000E+01",
    );
    let e = parse(&bad).unwrap_err();
    assert_eq!(
        field_error(&e),
        (9, 58, "record 7", "field 1 (ordinate data type)".into())
    );
    let msg = e.to_string();
    assert!(
        msg.starts_with("test.uff:9:") && msg.contains("6 (complex double)"),
        "{msg}"
    );

    let scalar = HAND_58.replace(
        R6,
        "    4         1    0         0 NONE               3   0 NONE               1   3",
    );
    let e = parse(&scalar).unwrap_err();
    assert_eq!(field_error(&e).2, "record 6");
    assert!(e.to_string().contains("0 (scalar) has no DOF"), "{e}");

    let stress = HAND_58.replace(
        R9,
        "         2    0    0    0 Stress               NONE                ",
    );
    let e = parse(&stress).unwrap_err();
    assert_eq!(
        field_error(&e),
        (11, 58, "record 9", "field 1 (specific data type)".into())
    );

    let clash = HAND_58.replace(
        R9,
        "        12    1    0    0 Acceleration         mm/s                ",
    );
    assert!(
        parse(&clash)
            .unwrap_err()
            .to_string()
            .contains("velocity unit")
    );

    let unknown = HAND_58.replace(
        R9,
        "        12    1    0    0 Acceleration         furlong             ",
    );
    assert_eq!(
        field_error(&parse(&unknown).unwrap_err()).3,
        "field 6 (units label)"
    );

    let time = HAND_58.replace(
        "        18    0    0    0 Frequency            Hz",
        "        17    0    0    0 Time                 s ",
    );
    assert!(
        parse(&time)
            .unwrap_err()
            .to_string()
            .contains("frequency abscissa")
    );

    let garbage = HAND_58.replace("  -5.00000000000E-01", "  -5.0000000zz00E-01");
    let e = parse(&garbage).unwrap_err();
    assert_eq!(
        field_error(&e),
        (15, 58, "record 12", "data value 5".into())
    );

    let extra = HAND_58.replace("   6.25000000000E-02\n", "   6.25000000000E-02   1.0\n");
    assert!(
        parse(&extra)
            .unwrap_err()
            .to_string()
            .contains("more than 6 values")
    );

    let e = parse("    -1\n    58\nNONE\n    -1\n").unwrap_err();
    assert_eq!(field_error(&e).0, 4);

    let e = parse("hello\n").unwrap_err();
    assert!(matches!(e, UffError::Delimiter { line: 1, .. }), "{e}");
    let e = parse("    -1\n  58x\n    -1\n").unwrap_err();
    assert!(matches!(e, UffError::DatasetNumber { line: 2, .. }), "{e}");
}

#[test]
fn truncated_files_name_the_last_line_and_the_dataset() {
    // Cut inside the data: lines 1-14 remain.
    let cut = &HAND_58[..HAND_58.find("  -5.0000").unwrap()];
    let e = parse(cut).unwrap_err();
    match &e {
        UffError::Truncated {
            line,
            dataset,
            start,
            ..
        } => assert_eq!((*line, *dataset, *start), (14, Some(58), 1)),
        other => panic!("{other}"),
    }
    assert!(
        e.to_string()
            .starts_with("test.uff:14: the file ends inside dataset 58"),
        "{e}"
    );
    assert!(matches!(
        parse("\n\n    -1\n").unwrap_err(),
        UffError::Truncated {
            line: 3,
            dataset: None,
            start: 3,
            ..
        }
    ));

    // Binary data cut short.
    let set = sample_set(Quantity::Mobility, &frequency_lines(1.0, 3.0, 0.5));
    let bin = write_uff58(&set, true);
    let cut = &bin[..bin.len() - 20];
    let e = parse_uff(cut, "b.uff").unwrap_err();
    assert!(
        matches!(
            e,
            UffError::Truncated {
                dataset: Some(58),
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("bytes of binary data"), "{e}");
}

#[test]
fn mixed_lines_quantities_and_pairs_are_refused_naming_both_records() {
    const R6_NODE_2: &str =
        "    4         1    0         0 NONE               2   3 NONE               1   3";
    let other_pair = HAND_58.replace(R6, R6_NODE_2);
    // Increment 0.51 Hz instead of 0.5 Hz.
    let shifted = other_pair.replace("  1.00000E+01  5.00000E-01", "  1.00000E+01  5.10000E-01");
    let f = parse(&format!("{HAND_58}{shifted}")).unwrap();
    let e = to_frf_set(&f.frfs).unwrap_err();
    match &e {
        UffError::Inconsistent {
            first_line,
            second_line,
            reason,
            ..
        } => {
            assert_eq!((*first_line, *second_line), (2, 18));
            assert!(
                reason.contains("line 1 is 10.5 Hz in the first and 10.51 Hz"),
                "{reason}"
            );
        }
        other => panic!("{other}"),
    }
    assert!(e.to_string().contains("test.uff:2 and test.uff:18"), "{e}");

    let velocity = other_pair.replace(
        R9,
        "        11    1    0    0 Velocity             m/s                 ",
    );
    let f = parse(&format!("{HAND_58}{velocity}")).unwrap();
    let e = to_frf_set(&f.frfs).unwrap_err();
    assert!(
        e.to_string().contains("accelerance, the second mobility"),
        "{e}"
    );

    let f = parse(&format!("{HAND_58}{HAND_58}")).unwrap();
    let e = to_frf_set(&f.frfs).unwrap_err();
    assert!(e.to_string().contains("both hold H(3:uz, 1:uz)"), "{e}");
    assert!(matches!(to_frf_set(&[]), Err(UffError::NoFrfs)));

    // Lines within 1e-9 relative are the same lines; the first record's are kept.
    let a = f.frfs[0].clone();
    let mut b = a.clone();
    b.response = "4:uz".parse().unwrap();
    b.freqs_hz[2] *= 1.0 + 1e-12;
    let set = to_frf_set(&[a, b]).unwrap();
    assert_eq!(set.freqs_hz, vec![10.0, 10.5, 11.0]);
}

/// Values with mixed signs and magnitudes, none a short decimal.
fn sample_set(quantity: Quantity, freqs: &[f64]) -> FrfSet {
    let pairs = FrfSet::all_pairs(
        &[
            "1:ux".parse().unwrap(),
            "2:rz".parse().unwrap(),
            "30000:uy".parse().unwrap(),
        ],
        &["1:ux".parse().unwrap(), "5:rx".parse().unwrap()],
    );
    let values = Mat::from_fn(freqs.len(), pairs.len(), |i, j| {
        let t = (i * 7 + j * 3) as f64 + 0.123_456_789;
        c64::new(
            t.sin() * 10f64.powi(j as i32 - 4) / 3.0,
            -t.cos() * 10f64.powi(2 - j as i32) / 7.0,
        )
    });
    FrfSet {
        quantity,
        freqs_hz: freqs.to_vec(),
        pairs,
        values,
    }
}

/// `a` equals `b` exactly (`rel` = 0), as single-precision numbers (`rel` < 0), or within
/// `rel` relative.
fn same(a: f64, b: f64, rel: f64) -> bool {
    if rel == 0.0 {
        a.to_bits() == b.to_bits()
    } else if rel < 0.0 {
        (a as f32).to_bits() == (b as f32).to_bits()
    } else {
        (a - b).abs() <= rel * b.abs()
    }
}

#[test]
fn round_trips_in_every_encoding_type_spacing_and_quantity() {
    let even = frequency_lines(2.0, 6.5, 0.5);
    let uneven = [
        1.0,
        1.3,
        std::f64::consts::E,
        PI,
        10.0 / 3.0,
        100.123_456_789,
        2000.5,
    ];
    let encodings = [
        UffEncoding::Ascii,
        UffEncoding::AsciiExact,
        UffEncoding::Binary(ByteOrder::Little),
        UffEncoding::Binary(ByteOrder::Big),
    ];
    let types = [
        OrdinateType::RealSingle,
        OrdinateType::RealDouble,
        OrdinateType::ComplexSingle,
        OrdinateType::ComplexDouble,
    ];
    let mut cases = 0;
    for quantity in [
        Quantity::Receptance,
        Quantity::Mobility,
        Quantity::Accelerance,
    ] {
        for freqs in [&even[..], &uneven[..]] {
            let set = sample_set(quantity, freqs);
            for force_uneven in [false, true] {
                for ord in types {
                    for enc in encodings {
                        let mut recs = records_from_set(&set);
                        for r in &mut recs {
                            r.ordinate = ord;
                            if force_uneven {
                                r.abscissa = Abscissa::Uneven;
                            }
                        }
                        let bytes = write_uff58_records(&recs, enc);
                        let back = parse_uff(&bytes, "rt.uff")
                            .unwrap_or_else(|e| panic!("{enc:?} {ord}: {e}"))
                            .frfs;
                        assert_eq!(back.len(), recs.len());
                        let ascii = enc == UffEncoding::Ascii;
                        let double = ord.is_double();
                        let is_even = !force_uneven && std::ptr::eq(freqs, &even[..]);
                        let exact_text = enc == UffEncoding::AsciiExact;
                        // ASCII single data are read as the nearest double of their text.
                        let value_tol = match (ascii, double) {
                            (true, true) => 1e-12,
                            (true, false) => 1e-5,
                            (false, false) if exact_text => -1.0,
                            (false, _) => 0.0,
                        };
                        let freq_tol = match (is_even, ascii, double) {
                            (true, _, _) => 0.0,
                            (false, true, _) => 1e-6,
                            (false, false, false) if exact_text => -1.0,
                            (false, false, _) => 0.0,
                        };
                        let cast = |v: f64| if double { v } else { f64::from(v as f32) };
                        for (r, w) in back.iter().zip(&recs) {
                            assert_eq!((r.response, r.reference), (w.response, w.reference));
                            assert_eq!((r.quantity, r.ordinate), (quantity, ord));
                            assert_eq!(r.binary.is_some(), matches!(enc, UffEncoding::Binary(_)));
                            assert_eq!(matches!(r.abscissa, Abscissa::Even { .. }), is_even);
                            assert!(r.conversions.is_empty(), "{:?}", r.conversions);
                            for (a, b) in r.freqs_hz.iter().zip(&w.freqs_hz) {
                                let b = if is_even { *b } else { cast(*b) };
                                assert!(same(*a, b, freq_tol), "{enc:?} {ord}: {a} vs {b}");
                            }
                            for (a, b) in r.values.iter().zip(&w.values) {
                                let im = if ord.is_complex() { cast(b.im) } else { 0.0 };
                                assert!(
                                    same(a.re, cast(b.re), value_tol) && same(a.im, im, value_tol),
                                    "{enc:?} {ord} {quantity:?}: {a} vs {b}"
                                );
                            }
                        }
                        if ord == OrdinateType::ComplexDouble && !ascii {
                            let got = to_frf_set(&back).unwrap();
                            assert_eq!(got.pairs, set.pairs);
                            assert_eq!(got.freqs_hz, set.freqs_hz);
                            assert!(got.values == set.values);
                        }
                        cases += 1;
                    }
                }
            }
        }
    }
    assert_eq!(cases, 3 * 2 * 2 * 4 * 4);
}

#[test]
fn uneven_double_58b_with_single_precision_abscissa_and_miscounted_header_is_read() {
    let set = sample_set(Quantity::Receptance, &[1.0, 2.5, 4.0]);
    let mut recs = records_from_set(&set);
    recs.truncate(1);
    recs[0].abscissa = Abscissa::Uneven;
    let bytes = write_uff58_records(&recs, UffEncoding::Binary(ByteOrder::Little));
    // The 13 ASCII lines (delimiter, header, records 1-11), then 3 × 24 bytes of data.
    let text_end = bytes
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .nth(12)
        .map(|(k, _)| k + 1)
        .unwrap();
    let head = String::from_utf8(bytes[..text_end].to_vec()).unwrap();
    assert!(head.contains("          11          72"), "{head}");
    // Re-encode the abscissa as f32 (20 bytes per point), and declare a wrong byte count
    // as some writers do.
    let mut file = head
        .replacen("          11          72", "          11          24", 1)
        .into_bytes();
    for p in bytes[text_end..bytes.len() - 7].chunks(24) {
        let x = f64::from_le_bytes(p[..8].try_into().unwrap());
        file.extend_from_slice(&(x as f32).to_le_bytes());
        file.extend_from_slice(&p[8..]);
    }
    file.extend_from_slice(b"    -1\n");
    let f = parse_uff(&file, "w.uff").unwrap();
    assert_eq!(f.frfs[0].freqs_hz, vec![1.0, 2.5, 4.0]);
    assert_eq!(f.frfs[0].values, recs[0].values);
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("declares 24 bytes") && w.contains("60 bytes read")),
        "{:?}",
        f.warnings
    );
}

#[test]
fn standard_ascii_keeps_the_fixed_columns_of_the_layout() {
    let set = sample_set(Quantity::Accelerance, &frequency_lines(0.0, 40.0, 0.05));
    assert_eq!(even_spacing(&set.freqs_hz), Some((0.0, 0.05)));
    assert_eq!(
        even_spacing(&frequency_lines(1.0, 10.0, 0.05)),
        Some((1.0, 0.05))
    );
    assert_eq!(even_spacing(&[1.0, 2.0, 3.5]), None);
    let text = String::from_utf8(write_uff58(&set, false)).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[7].len(), 80, "record 6: {}", lines[7]);
    assert_eq!(lines[8].len(), 69, "record 7: {}", lines[8]);
    // Record 7 holds 7 significant digits per 13-column field (E13.5 holds 6).
    assert!(
        lines[8].ends_with(" 0.000000E+00 5.000000E-02 0.000000E+00"),
        "{}",
        lines[8]
    );
    // A fixed-column reader (20 columns per value) gets every value.
    let first = lines[13];
    assert_eq!(first.len(), 80);
    for k in 0..4 {
        let v: f64 = first[20 * k..20 * (k + 1)].trim().parse().unwrap();
        let want = set.values[(k / 2, 0)];
        let want = if k % 2 == 0 { want.re } else { want.im };
        assert!((v - want).abs() <= 1e-12 * want.abs(), "{v} vs {want}");
    }
}

fn fixture_set() -> FrfSet {
    // Two-mode modal receptance of a four-DOF chain driven at 1:ux:
    // H_i1 = Σ_r φ_ir φ_1r / (ω_r² − ω² + 2iζω_rω).
    let phi = [[0.30, 0.55], [0.50, 0.35], [0.55, -0.30], [0.60, -0.60]];
    let omega_r = [2.0 * PI * 12.0, 2.0 * PI * 31.0];
    let zeta = 0.02;
    let freqs = frequency_lines(5.0, 50.0, 5.0);
    let pairs: Vec<FrfPair> = (1..=4)
        .map(|i| FrfPair {
            response: DofId::new(i, Component::Ux),
            excitation: DofId::new(1, Component::Ux),
        })
        .collect();
    let values = Mat::from_fn(freqs.len(), 4, |k, i| {
        let w = 2.0 * PI * freqs[k];
        (0..2)
            .map(|r| {
                let d = c64::new(omega_r[r] * omega_r[r] - w * w, 2.0 * zeta * omega_r[r] * w);
                c64::new(phi[i][r] * phi[0][r], 0.0) / d
            })
            .fold(c64::new(0.0, 0.0), |a, b| a + b)
    });
    FrfSet {
        quantity: Quantity::Receptance,
        freqs_hz: freqs,
        pairs,
        values,
    }
}

#[test]
fn the_four_dof_fixture_reads_back_as_the_synthetic_set() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/uff/four_dof_receptance.uff"
    );
    let set = fixture_set();
    let written = write_uff58(&set, false);
    if std::env::var_os("FEMU_BLESS").is_some() {
        std::fs::create_dir_all(Path::new(path).parent().unwrap()).unwrap();
        std::fs::write(path, &written).unwrap();
    }
    let file = read_uff(path).unwrap();
    assert!(
        file.warnings.is_empty() && file.conversions.is_empty(),
        "{:?}",
        file.warnings
    );
    let got = to_frf_set(&file.frfs).unwrap();
    assert_eq!(got.quantity, Quantity::Receptance);
    assert_eq!(got.pairs, set.pairs);
    assert_eq!(got.freqs_hz, set.freqs_hz);
    assert_eq!((got.values.nrows(), got.values.ncols()), (10, 4));
    for i in 0..10 {
        for j in 0..4 {
            let (a, b) = (got.values[(i, j)], set.values[(i, j)]);
            assert!((a - b).norm() <= 1e-12 * b.norm(), "({i}, {j}): {a} vs {b}");
        }
    }
    assert!(
        std::fs::read(path).unwrap() == written,
        "fixtures/uff/four_dof_receptance.uff is not what the writer makes now; bless on purpose with FEMU_BLESS=1"
    );
}

fn damaged_sample(binary: bool) -> Vec<u8> {
    let set = sample_set(Quantity::Mobility, &[1.0, 2.0, 3.5]);
    let mut bytes = write_uff2411(&[(1, [0.0, 1.0, 2.0])]);
    bytes.extend(write_uff58(&set, binary));
    bytes.extend_from_slice(HAND_58.as_bytes());
    bytes
}

proptest! {
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..3000)) {
        let _ = parse_uff(&bytes, "random.uff");
    }

    #[test]
    fn random_text_after_a_58_header_never_panics(body in "[ -~\n]{0,600}", binary in any::<bool>(), n in 0usize..2000) {
        let head = if binary {
            format!("    -1\n    58b     1     2          11{n:>12}     0     0           0           0\n")
        } else {
            "    -1\n    58\n".to_string()
        };
        let _ = parse_uff(format!("{head}{body}").as_bytes(), "text.uff");
    }

    #[test]
    fn damaged_files_never_panic(
        binary in any::<bool>(),
        cut in 0usize..8000,
        flips in prop::collection::vec((0usize..8000, any::<u8>()), 0..6),
    ) {
        let mut bytes = damaged_sample(binary);
        for (i, b) in flips {
            let k = i % bytes.len();
            bytes[k] = b;
        }
        bytes.truncate(cut);
        let _ = parse_uff(&bytes, "damaged.uff");
    }
}

/// Record 6 with zero nodes and directions, the DOFs named in ID line 1.
fn with_id_dofs(id1: &str) -> String {
    HAND_58.replace("H 3:uz / 1:uz accelerance", id1).replace(
        R6,
        "    4         1    0         0 NONE               0   0 NONE               0   0",
    )
}

#[test]
fn id_line_dof_spellings_are_read() {
    use super::header58::id_line_dofs;
    assert_eq!(id_line_dofs("Pt12:+Z / Pt1:+Z"), vec![(12, 3), (1, 3)]);
    assert_eq!(id_line_dofs("FRF 12:-Y/1:+X"), vec![(12, -2), (1, 1)]);
    assert_eq!(id_line_dofs("Pt 12.Z- Pt 1.Z+"), vec![(12, -3), (1, 3)]);
    assert_eq!(
        id_line_dofs("Point 7:+RX, Point 2:TY"),
        vec![(7, 4), (2, 2)]
    );
    assert_eq!(id_line_dofs("1:+Z"), vec![(1, 3)]);
    // Not DOFs: femu's own component names, bare words, both signs, trailing letters.
    for none in [
        "H 3:uz / 1:uz",
        "Run 1 X",
        "12:+Z+",
        "12:+Zeta",
        "18-Apr-16 13:49:58",
    ] {
        assert!(id_line_dofs(none).is_empty(), "{none}");
    }
}

#[test]
fn dofs_named_only_in_the_id_line_are_read_and_recorded() {
    let f = parse(&with_id_dofs("Pt12:+Z / Pt1:-Z")).unwrap();
    let r = &f.frfs[0];
    assert_eq!(r.response, "12:uz".parse().unwrap());
    assert_eq!(r.reference, "1:uz".parse().unwrap());
    assert_eq!((r.response_direction, r.reference_direction), (3, -3));
    assert!(r.sign_flipped);
    assert_eq!(r.values[0], c64::new(-1.0, 2.0));
    assert!(
        r.conversions
            .iter()
            .any(|c| c.contains("read from ID line 1")
                && c.contains("response node 12 direction +3")
                && c.contains("reference node 1 direction -3")),
        "{:?}",
        r.conversions
    );
    // The sign after the axis; record 6's nodes given and agreeing.
    let agree = with_id_dofs("Pt 3.Z- Pt 1.Z+").replace(
        "NONE               0   0 NONE               0   0",
        "NONE               3   0 NONE               1   0",
    );
    let r = &parse(&agree).unwrap().frfs[0];
    assert_eq!(
        (r.response, r.response_direction),
        ("3:uz".parse().unwrap(), -3)
    );
    // A node that contradicts record 6 is refused, naming the ID line.
    let clash = agree.replace("Pt 3.Z-", "Pt 4.Z-");
    let e = parse(&clash).unwrap_err();
    assert_eq!(
        field_error(&e),
        (3, 58, "record 1", "field 1 (ID line)".into())
    );
    assert!(e.to_string().contains("response node 3 of record 6"), "{e}");
    // No DOF in the ID lines: record 6's zero direction is refused as before.
    let e = parse(&with_id_dofs("accelerance")).unwrap_err();
    assert_eq!(
        field_error(&e),
        (8, 58, "record 6", "field 7 (response direction)".into())
    );
    assert!(e.to_string().contains("named in the ID lines"), "{e}");
}

#[test]
fn trailing_zero_padding_is_dropped_with_a_warning_but_a_value_is_not() {
    let last = "  -5.00000000000E-01   6.25000000000E-02\n";
    let padded = HAND_58.replace(last, &format!("{last}   0.0   0.0\n   0.00000E+00\n"));
    let f = parse(&padded).unwrap();
    assert_eq!(f.frfs[0].values.len(), 3);
    assert!(
        f.warnings.iter().any(|w| w.contains("test.uff:16")
            && w.contains("3 zero value(s)")
            && w.contains("padding")),
        "{:?}",
        f.warnings
    );
    let extra = HAND_58.replace(last, &format!("{last}   0.0   1.0\n"));
    let e = parse(&extra).unwrap_err();
    assert_eq!(field_error(&e).0, 16);
    assert!(e.to_string().contains("value 8 being 1.0"), "{e}");
}

#[test]
fn lab_unit_spellings_convert_and_say_how_they_were_read() {
    let r10 = "        13    0    1    0 Force                N                   ";
    let none10 = "        13    0    1    0 Force                NONE                ";
    for label in ["(1/N)*(m/s²)", "m/(s^2 N)", "m·s⁻²/N", "(m/s2)/N"] {
        let text = HAND_58
            .replace(
                R9,
                &format!("        12    1    0    0 Acceleration         {label}"),
            )
            .replace(r10, none10);
        let f = parse(&text).unwrap_or_else(|e| panic!("{label}: {e}"));
        let r = &f.frfs[0];
        assert_eq!(r.quantity, Quantity::Accelerance, "{label}");
        assert_eq!(r.values[0], c64::new(1.0, -2.0), "{label}");
        if label == "(m/s2)/N" {
            // A plain spelling, read without a note (SI, so nothing converted).
            assert!(r.conversions.is_empty(), "{:?}", r.conversions);
            continue;
        }
        assert!(
            r.conversions
                .iter()
                .any(|c| c.contains(&format!("`{label}` read as m/s^2/N"))),
            "{label}: {:?}",
            r.conversions
        );
    }
    // g over a newton in an expression, and a record 10 moment spelled `N·mm`.
    let text = HAND_58
        .replace(R9, "        12    1    0    0 Acceleration         (g)/(N)")
        .replace(r10, none10);
    let r = &parse(&text).unwrap().frfs[0];
    assert!((r.values[0].re - STANDARD_GRAVITY).abs() < 1e-14);
    assert!(
        r.conversions.iter().any(|c| c.contains("×9.80665e0")),
        "{:?}",
        r.conversions
    );
    let text = HAND_58
        .replace(R9, "         0    0    0    0 NONE                 mm/s^2")
        .replace(r10, "        13    0    1    0 Force                kN·mm");
    let e = parse(&text).unwrap_err();
    // A moment under a translational reference is refused as a plain label would be.
    assert_eq!(field_error(&e).2, "record 10");
}

/// Coordinate systems in mm (dataset 164): 5 Cartesian turned 90° about z with its origin at
/// (1, 2, 3) m (2420); 6 cylindrical at (0, 0, 0.5) m (2420); 8 spherical at the origin (2420);
/// 7 Cartesian defined by three points in system 5 (dataset 18 at line 40, after its nodes).
const SYSTEMS: &str = concat!(
    "    -1\n",
    "   164\n",
    "         5mm (milli newton)               2\n",
    "  1.00000000000000000D+03  1.00000000000000000D+03  1.00000000000000000D+00\n",
    "  2.73150000000000000D+02\n",
    "    -1\n",
    "    -1\n",
    "  2420\n",
    "         1\n",
    "Part\n",
    "         5         0         8\n",
    "turned\n",
    "   0.0000000000000000D+00   1.0000000000000000D+00   0.0000000000000000D+00\n",
    "  -1.0000000000000000D+00   0.0000000000000000D+00   0.0000000000000000D+00\n",
    "   0.0000000000000000D+00   0.0000000000000000D+00   1.0000000000000000D+00\n",
    "   1.0000000000000000D+03   2.0000000000000000D+03   3.0000000000000000D+03\n",
    "         6         1         8\n",
    "cylinder\n",
    "   1.0000000000000000D+00   0.0000000000000000D+00   0.0000000000000000D+00\n",
    "   0.0000000000000000D+00   1.0000000000000000D+00   0.0000000000000000D+00\n",
    "   0.0000000000000000D+00   0.0000000000000000D+00   1.0000000000000000D+00\n",
    "   0.0000000000000000D+00   0.0000000000000000D+00   5.0000000000000000D+02\n",
    "         8         2         8\n",
    "sphere\n",
    "   1.0000000000000000D+00   0.0000000000000000D+00   0.0000000000000000D+00\n",
    "   0.0000000000000000D+00   1.0000000000000000D+00   0.0000000000000000D+00\n",
    "   0.0000000000000000D+00   0.0000000000000000D+00   1.0000000000000000D+00\n",
    "   0.0000000000000000D+00   0.0000000000000000D+00   0.0000000000000000D+00\n",
    "    -1\n",
    "    -1\n",
    "    15\n",
    "         1         5         5         8  1.00000E+03  0.00000E+00  0.00000E+00\n",
    "         2         6         0         8  2.00000E+03  9.00000E+01  1.00000E+03\n",
    "         3         7         0         8  1.00000E+03  2.00000E+03  3.00000E+03\n",
    "         4         8         0         8  2.00000E+03  9.00000E+01  9.00000E+01\n",
    "         5         0         0         8  1.00000E+03  0.00000E+00  0.00000E+00\n",
    "    -1\n",
    "    -1\n",
    "    18\n",
    "         7         0         5         8         1\n",
    "from points\n",
    "  0.00000E+00  0.00000E+00  0.00000E+00  0.00000E+00  0.00000E+00  1.00000E+03\n",
    "  1.00000E+03  0.00000E+00  0.00000E+00\n",
    "    -1\n",
    "    -1\n",
    "    82\n",
    "         1         4         8\n",
    "edge\n",
    "         1         2         0         5\n",
    "    -1\n",
    "    -1\n",
    "   151\n",
    "plate.mf1\n",
    "bonded plate, 12 points\n",
    "Simcenter Testlab\n",
    "26-Nov-26 09:00:00\n",
    "26-Nov-26 09:10:00\n",
    "Simcenter Testlab 2306\n",
    "26-Nov-26 09:20:00\n",
    "    -1\n",
);

#[test]
fn coordinate_systems_bring_nodes_to_global_as_computed_by_hand() {
    let f = parse(SYSTEMS).unwrap();
    let want: [(u64, [f64; 3]); 5] = [
        // System 5: local (1, 0, 0) m along the turned x axis (global +y) from (1, 2, 3).
        (1, [1.0, 3.0, 3.0]),
        // System 6: r = 2 m, θ = 90° (not a length: not scaled), z = 1 m above (0, 0, 0.5).
        (2, [0.0, 2.0, 1.5]),
        // System 7: axes (0,0,1), (1,0,0), (0,1,0) from (1, 2, 3): 1·ez' + 2·ex' + 3·ey'.
        (3, [3.0, 5.0, 4.0]),
        // System 8: r = 2 m, θ = 90° from z, φ = 90° about z.
        (4, [0.0, 2.0, 0.0]),
        (5, [1.0, 0.0, 0.0]),
    ];
    for ((id, xyz), (wid, w)) in f.nodes.iter().zip(want) {
        assert_eq!(*id, wid);
        for k in 0..3 {
            assert!((xyz[k] - w[k]).abs() < 1e-12, "node {id}: {xyz:?} vs {w:?}");
        }
    }
    let s7 = f.coordinate_systems.iter().find(|c| c.id == 7).unwrap();
    assert_eq!(s7.axes, [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    assert_eq!((s7.dataset, s7.line), (18, 40));
    // The displacement system is kept per node and said so; each transformation recorded.
    assert_eq!(f.node_systems[0], [5, 5, 8]);
    assert!(
        f.warnings.iter().any(|w| w.contains(
            "nodes measure in displacement systems other than the global one (system 5: node 1)"
        )),
        "{:?}",
        f.warnings
    );
    for s in [5, 6, 7, 8] {
        assert!(
            f.conversions
                .iter()
                .any(|c| c.contains(&format!("definition system {s} "))),
            "{s}: {:?}",
            f.conversions
        );
    }
    assert_eq!(f.trace_lines.len(), 1);
    assert_eq!(f.trace_lines[0].nodes, vec![1, 2, 0, 5]);
    assert_eq!(f.trace_lines[0].name, "edge");
    let h = f.header.as_ref().unwrap();
    assert_eq!(
        (h.model.as_str(), h.program.as_str(), h.written.as_str()),
        ("plate.mf1", "Simcenter Testlab 2306", "26-Nov-26 09:20:00")
    );
    assert!(f.skipped.is_empty(), "{:?}", f.skipped);
}

#[test]
fn bad_coordinate_systems_are_named_with_line_record_and_field() {
    // A reference system that is never defined.
    let e = parse(&SYSTEMS.replace(
        "         7         0         5         8         1\n",
        "         7         0         9         8         1\n",
    ))
    .unwrap_err();
    assert_eq!(
        field_error(&e),
        (
            40,
            18,
            "record 1",
            "field 3 (reference coordinate system)".into()
        )
    );
    // Three points on one line.
    let e = parse(&SYSTEMS.replace(
        "  1.00000E+03  0.00000E+00  0.00000E+00\n    -1\n    -1\n    82",
        "  0.00000E+00  0.00000E+00  2.00000E+03\n    -1\n    -1\n    82",
    ))
    .unwrap_err();
    assert_eq!(field_error(&e).0, 42);
    assert!(e.to_string().contains("not on one line"), "{e}");
    // Axes that are not orthonormal.
    let e = parse(&SYSTEMS.replacen(
        "   0.0000000000000000D+00   1.0000000000000000D+00   0.0000000000000000D+00\n",
        "   0.0000000000000000D+00   2.0000000000000000D+00   0.0000000000000000D+00\n",
        1,
    ))
    .unwrap_err();
    assert_eq!(field_error(&e).1, 2420);
    // An unknown type, and a trace line cut short.
    let e = parse(&SYSTEMS.replace(
        "         6         1         8\n",
        "         6         4         8\n",
    ))
    .unwrap_err();
    assert_eq!(
        field_error(&e),
        (
            17,
            2420,
            "record 3",
            "field 2 (coordinate system type)".into()
        )
    );
    let e = parse(&SYSTEMS.replace(
        "         1         4         8\n",
        "         1         9         8\n",
    ))
    .unwrap_err();
    assert_eq!(field_error(&e).1, 82);
}
