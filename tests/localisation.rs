//! The shipped localisation pipeline (CASES.md C2 §5.6): what the leverage (5.9) and the
//! eigenvalue sensitivities (5.3) say about the softened strip 7 of the bent plate.

mod common;

use common::*;
use femu::artefact::codec::read_dir;
use femu::artefact::leverage::leverages;
use std::path::Path;

/// Elements of strip 7 (the seventh of 14 along the length, one per row of seven).
const STRIP_7: [u64; 7] = [7, 21, 35, 49, 63, 77, 91];

fn table(out: &Path, stage: &str) -> Vec<(String, f64, i64)> {
    leverages(&read_dir(&out.join(stage).join("leverage")).unwrap()).unwrap()
}

/// Leverage of strip 7 over the best other strip, and its rank.
fn strip_7(out: &Path, stage: &str) -> (f64, i64) {
    let t = table(out, stage);
    let e7 = t.iter().find(|r| r.0 == "e7").unwrap();
    let other = t
        .iter()
        .filter(|r| r.0 != "e7")
        .map(|r| r.1)
        .fold(0.0, f64::max);
    (e7.1 / other, e7.2)
}

/// Ranks of strip 7's elements among every shell's.
fn element_ranks(out: &Path, stage: &str) -> Vec<i64> {
    let t = table(out, stage);
    assert_eq!(t.len(), 98);
    STRIP_7
        .iter()
        .map(|e| t.iter().find(|r| r.0 == format!("e{e}")).unwrap().2)
        .collect()
}

/// Case 2: with a 10 % error strip 7 ranks first (its leverage a little above the next strip's);
/// with the thesis's 50 % error it ranks near last (the first-order leverage saturates; see the
/// pipeline). Case 1: with 10 % the largest element leverage lies in strip 7 and three of its
/// elements are in the top quartile; with 50 % none is in the top fifth. The eigenvalue
/// sensitivities point at strips 7 and 8 in the first elastic mode only. Every figure is a PNG.
#[test]
fn bent_plate_localise_reproduces_c2_section_5_6() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let (_, report, cache) = run(
        &pipeline("bent-plate-localise"),
        &tmp.path().join("cache"),
        &[],
    );
    femu::pipeline::materialise(&report, &cache, &out).unwrap();

    // Case 2.
    let (ratio_small, rank_small) = strip_7(&out, "case2_leverage_small");
    let (ratio_large, rank_large) = strip_7(&out, "case2_leverage");
    println!("case 2, 10 %: strip 7 rank {rank_small}, leverage / best other {ratio_small:.4}");
    println!("case 2, 50 %: strip 7 rank {rank_large}, leverage / best other {ratio_large:.4}");
    assert_eq!(rank_small, 1);
    assert!(ratio_small > 1.005 && ratio_small < 1.1, "{ratio_small}");
    assert!(rank_large >= 10, "{rank_large}");
    assert!(ratio_large < 0.1, "{ratio_large}");

    // Case 1.
    let small = element_ranks(&out, "case1_leverage_small");
    let large = element_ranks(&out, "case1_leverage");
    println!("case 1, 10 %: ranks of strip 7's elements {small:?} of 98");
    println!("case 1, 50 %: ranks of strip 7's elements {large:?} of 98");
    assert!(small.contains(&1), "{small:?}");
    assert!(small.iter().filter(|r| **r <= 24).count() >= 3, "{small:?}");
    assert!(large.iter().all(|r| *r > 20), "{large:?}");

    // Eigenvalue sensitivities per strip: mode 7 (the first elastic) peaks at strips 7 and 8.
    let a = read_dir(&out.join("case2_eigen").join("sensitivity")).unwrap();
    let t = a.table("sensitivities").unwrap();
    let (cand, mode, norm) = (
        t.strs("sensitivities", "candidate").unwrap(),
        t.i64s("sensitivities", "mode").unwrap(),
        t.f64s("sensitivities", "normalised").unwrap(),
    );
    let modes: Vec<i64> = a
        .table("modes")
        .unwrap()
        .i64s("modes", "mode")
        .unwrap()
        .to_vec();
    assert_eq!(modes, [7, 8, 9, 10, 11, 12]);
    for m in modes {
        let at = |s: &str| {
            (0..cand.len())
                .find(|&i| cand[i] == s && mode[i] == m)
                .map(|i| norm[i])
                .unwrap()
        };
        let (e7, e8) = (at("e7"), at("e8"));
        println!("mode {m}: strip 7 {e7:.3}, strip 8 {e8:.3} of the largest");
        assert!((e7 - e8).abs() < 1e-3, "mode {m}: symmetry");
        if m == 7 {
            assert!(e7 > 0.999, "mode {m}: {e7}");
        } else {
            assert!(e7 < 0.7, "mode {m}: {e7}");
        }
    }

    for (stage, port, file) in [
        ("case1_leverage", "map", "map.png"),
        ("case2_leverage", "bars", "bars.png"),
        ("case1_eigen", "maps", "maps.png"),
        ("case2_eigen", "bars", "bars.png"),
    ] {
        let bytes = std::fs::read(out.join(stage).join(port).join(file)).unwrap();
        assert!(bytes.starts_with(b"\x89PNG"), "{stage}/{port}/{file}");
    }
    check_golden(
        "bent-plate-localise",
        &out,
        &[
            "case1_leverage/leverage",
            "case1_leverage_small/leverage",
            "case2_leverage/leverage",
            "case2_leverage_small/leverage",
            "case1_eigen/sensitivity",
            "case2_eigen/sensitivity",
        ],
    );
}
