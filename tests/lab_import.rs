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
        assert!(stdout.starts_with("same"), "{codec}: {stdout}");
    }
}
