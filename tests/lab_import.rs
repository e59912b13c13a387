//! Test data in from the lab (issue 25): Parquet from mainstream writers, tolerant UFF reading,
//! coordinate systems, modes, and FRFs from long-format tables.

mod common;

use common::{femu, root};
use femu::artefact::codec::{read_dir, read_parquet, write_dir};
use femu::artefact::kinds::frf_from_artefact;
use femu::artefact::{Column, Format};
use std::path::PathBuf;

fn parquet_fixture(name: &str) -> PathBuf {
    root().join("tests/fixtures/parquet").join(name)
}

const CODECS: [&str; 5] = ["none", "snappy", "gzip", "lz4", "zstd"];

/// Each codec pyarrow/pandas writes (snappy is pandas' default) reads to the same table and the
/// same FRFs as the uncompressed file.
#[test]
fn parquet_of_every_mainstream_codec_reads_through_the_artefact_reader() {
    let reference = read_dir(&parquet_fixture("frf-none")).unwrap();
    let set_ref = frf_from_artefact(&reference).unwrap();
    assert_eq!((set_ref.freqs_hz.len(), set_ref.pairs.len()), (40, 4));
    for codec in CODECS {
        let dir = parquet_fixture(&format!("frf-{codec}"));
        let table =
            read_parquet(&dir.join("frf.parquet")).unwrap_or_else(|e| panic!("{codec}: {e}"));
        assert_eq!(table.columns.len(), 5, "{codec}");
        assert!(
            matches!(table.columns[1].1, Column::Str(_)),
            "{codec}: large_string as text"
        );
        let a = read_dir(&dir).unwrap_or_else(|e| panic!("{codec}: {e}"));
        let set = frf_from_artefact(&a).unwrap();
        assert_eq!(set.pairs, set_ref.pairs, "{codec}");
        assert_eq!(set.freqs_hz, set_ref.freqs_hz, "{codec}");
        assert_eq!(set.values, set_ref.values, "{codec}");
    }
}

/// `femu diff` compares a pyarrow-written artefact of each codec with femu's own (zstd) copy.
#[test]
fn femu_diff_reads_parquet_of_every_mainstream_codec() {
    let tmp = tempfile::tempdir().unwrap();
    let ours = tmp.path().join("ours");
    std::fs::create_dir_all(&ours).unwrap();
    let mut a = read_dir(&parquet_fixture("frf-none")).unwrap();
    a.meta.remove("import_notes");
    write_dir(&a, &ours, Format::default(), None).unwrap();
    for codec in CODECS {
        let out = femu()
            .arg("diff")
            .arg(parquet_fixture(&format!("frf-{codec}")))
            .arg(&ours)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(
            out.status.code(),
            Some(0),
            "{codec}: {stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert!(
            stdout.lines().any(|l| l.starts_with("same")),
            "{codec}: {stdout}"
        );
    }
}

/// Runs a one-stage `frf.import` pipeline in `dir` and returns the imported set and its notes.
fn import_table(
    dir: &std::path::Path,
    with: &str,
) -> Result<(femu::frf::FrfSet, Vec<String>), String> {
    let file = dir.join("p.yaml");
    std::fs::write(
        &file,
        format!("name: imp\nstages:\n  imp:\n    kind: frf.import\n    with: {{{with}}}\n"),
    )
    .unwrap();
    let mut src = femu::pipeline::read_pipeline(&file).map_err(|e| e.to_string())?;
    src.apply_overrides(&[]).map_err(|e| e.to_string())?;
    let plan = femu::pipeline::plan(&src, &femu::stages::registry()).map_err(|e| e.to_string())?;
    let cache = femu::cache::Cache::open(&dir.join("cache")).unwrap();
    let opts = femu::pipeline::RunOptions {
        progress: femu::pipeline::ProgressMode::Quiet,
        ..Default::default()
    };
    let report = femu::pipeline::execute(&plan, &cache, &opts).map_err(|e| e.to_string())?;
    let key = report.stages[0].key.clone();
    let a = cache
        .read(&key, "frf", femu::artefact::ArtefactKind::Frf)
        .unwrap();
    let notes = a
        .meta
        .get("import_notes")
        .and_then(|v| v.as_array())
        .map(|v| {
            v.iter()
                .filter_map(|s| s.as_str().map(String::from))
                .collect()
        })
        .unwrap_or_default();
    Ok((frf_from_artefact(&a).unwrap(), notes))
}

/// A pandas-written (snappy, `:+X` labels) Parquet table and the same table as CSV import to
/// the FRFs of the artefact they came from.
#[test]
fn frf_import_reads_long_tables_from_parquet_and_csv() {
    let dir = tempfile::tempdir().unwrap();
    let reference = frf_from_artefact(&read_dir(&parquet_fixture("frf-none")).unwrap()).unwrap();
    std::fs::copy(
        parquet_fixture("lab-frf-snappy.parquet"),
        dir.path().join("lab.parquet"),
    )
    .unwrap();
    let (set, notes) = import_table(dir.path(), "path: lab.parquet, quantity: receptance").unwrap();
    assert_eq!(set.pairs, reference.pairs);
    assert_eq!(set.freqs_hz, reference.freqs_hz);
    assert_eq!(set.values, reference.values);
    assert!(notes.iter().any(|n| n.contains("taken as SI")), "{notes:?}");
    // The same rows as CSV in mm/N, with the table's unit column; `.txt` is read as UFF
    // unless `format:` says otherwise.
    let mut csv = String::from("freq_hz,response,excitation,re,im,unit\n");
    for (p, pair) in reference.pairs.iter().enumerate() {
        for (k, f) in reference.freqs_hz.iter().enumerate() {
            let v = reference.values[(k, p)] * 1e3;
            csv.push_str(&format!(
                "{f},{},{},{:e},{:e},mm/N\n",
                pair.response, pair.excitation, v.re, v.im
            ));
        }
    }
    std::fs::write(dir.path().join("lab.txt"), &csv).unwrap();
    let e = import_table(dir.path(), "path: lab.txt").unwrap_err();
    assert!(e.contains("lab.txt") && e.contains("delimiter"), "{e}");
    let (set, notes) = import_table(dir.path(), "path: lab.txt, format: csv").unwrap();
    assert_eq!(set.pairs, reference.pairs);
    for (a, b) in set
        .values
        .col_as_slice(0)
        .iter()
        .zip(reference.values.col_as_slice(0))
    {
        assert!((a - b).norm() <= 1e-12 * b.norm().max(1e-30), "{a} vs {b}");
    }
    assert!(
        notes.iter().any(|n| n.contains("`mm/N` converted")),
        "{notes:?}"
    );
    // A row removed: the pair's missing line is named.
    // Line 44 of the file is the third row of the second pair.
    let short: String = csv
        .lines()
        .enumerate()
        .filter(|(i, _)| *i != 43)
        .map(|(_, l)| format!("{l}\n"))
        .collect();
    std::fs::write(dir.path().join("short.csv"), short).unwrap();
    let e = import_table(dir.path(), "path: short.csv").unwrap_err();
    assert!(e.contains("short.csv") && e.contains("freq_hz"), "{e}");
}
