//! The HDF5 form of an artefact's tables: one file, `data.h5`, readable with h5py alone.
//!
//! Layout:
//!
//! ```text
//! /tables/<table name>                  group, one per table
//!     @column_order                     attribute: 1-D array of variable-length UTF-8 strings,
//!                                       the column names in table order
//!     <column name>                     1-D dataset per column: float64, int64 or
//!                                       variable-length UTF-8 strings
//! ```
//!
//! A zero-row table has zero-length datasets; a table without columns is an empty group with an
//! empty `column_order`. Blobs are not stored here (they are plain files beside `data.h5`).
//!
//! Object modification times are not recorded, so writing the same artefact twice gives
//! byte-identical files. On reading, files written by other tools are accepted when their columns
//! are 1-D float32/float64, signed or unsigned integer, or variable-length string datasets;
//! without `column_order` the columns are taken in name order.

use super::{Artefact, ArtefactError, Column, Table};
use hdf5::file::LibraryVersion;
use hdf5::types::{IntSize, TypeDescriptor, VarLenAscii, VarLenUnicode};
use hdf5::{Container, Dataset, File, Group, H5Type};
use ndarray::ArrayView1;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Display;
use std::path::Path;
use std::str::FromStr;

/// Name of the group holding one subgroup per table.
const TABLES_GROUP: &str = "tables";
/// Name of the group attribute listing the column names in order.
const COLUMN_ORDER: &str = "column_order";
/// Column types accepted on reading, as told to the user.
const SUPPORTED: &str = "femu reads 1-D datasets of float32/float64, int8–int64, uint8–uint64 \
                         and variable-length (UTF-8 or ASCII) strings";

fn decode(path: &Path, message: String) -> ArtefactError {
    ArtefactError::Decode {
        path: path.to_path_buf(),
        message,
    }
}

/// Builds an error-mapping closure that prefixes `context` to the cause.
fn ctx<'a, E: Display>(
    path: &'a Path,
    context: impl Display + 'a,
) -> impl FnOnce(E) -> ArtefactError + 'a {
    move |e| decode(path, format!("{context}: {e}"))
}

/// Names become HDF5 link names: they must be non-empty, not `.` and free of `/` and NUL.
fn check_name(path: &Path, what: &str, name: &str) -> Result<(), ArtefactError> {
    if name.is_empty() || name == "." || name.contains('/') || name.contains('\0') {
        return Err(decode(
            path,
            format!(
                "{what} `{name}` cannot be stored in HDF5: names must be non-empty, not `.`, and contain no `/` or NUL"
            ),
        ));
    }
    Ok(())
}

/// Writes the tables of `a` into the HDF5 file `path` (created or truncated); blobs are ignored.
pub fn write(a: &Artefact, path: &Path) -> Result<(), ArtefactError> {
    let file = File::with_options()
        .with_fcpl(|p| p.obj_track_times(false))
        .with_fapl(|p| p.libver_bounds(LibraryVersion::V18, LibraryVersion::V18))
        .create(path)
        .map_err(ctx(path, "cannot create HDF5 file"))?;
    write_tables(&file, a, path)?;
    file.close().map_err(ctx(path, "cannot close HDF5 file"))
}

fn write_tables(file: &File, a: &Artefact, path: &Path) -> Result<(), ArtefactError> {
    let root = file
        .create_group_builder()
        .obj_track_times(false)
        .create(TABLES_GROUP)
        .map_err(ctx(path, format!("cannot create group `/{TABLES_GROUP}`")))?;
    for (name, (table, _storage)) in &a.tables {
        check_name(path, "table name", name)?;
        table
            .check_lengths(name)
            .map_err(|e| decode(path, e.to_string()))?;
        write_table(&root, table, name, path)?;
    }
    Ok(())
}

fn write_table(root: &Group, table: &Table, name: &str, path: &Path) -> Result<(), ArtefactError> {
    let where_ = format!("table `{name}`");
    let group = root
        .create_group_builder()
        .obj_track_times(false)
        .create(name)
        .map_err(ctx(path, format!("{where_}: cannot create group")))?;
    let mut seen = BTreeSet::new();
    let mut order = Vec::with_capacity(table.columns.len());
    for (col_name, _) in &table.columns {
        check_name(path, &format!("{where_}: column name"), col_name)?;
        if !seen.insert(col_name.as_str()) {
            return Err(decode(
                path,
                format!("{where_}: column `{col_name}` appears twice"),
            ));
        }
        order.push(
            to_vlen(col_name).map_err(ctx(path, format!("{where_}: column name `{col_name}`")))?,
        );
    }
    group
        .new_attr_builder()
        .with_data(ArrayView1::from(order.as_slice()))
        .create(COLUMN_ORDER)
        .map_err(ctx(
            path,
            format!("{where_}: cannot write attribute `{COLUMN_ORDER}`"),
        ))?;
    for (col_name, column) in &table.columns {
        let here = format!("{where_}, column `{col_name}`");
        let builder = group.new_dataset_builder().obj_track_times(false);
        let created = match column {
            Column::F64(v) => builder
                .with_data(ArrayView1::from(v.as_slice()))
                .create(col_name.as_str()),
            Column::I64(v) => builder
                .with_data(ArrayView1::from(v.as_slice()))
                .create(col_name.as_str()),
            Column::I32(v) => builder
                .with_data(ArrayView1::from(v.as_slice()))
                .create(col_name.as_str()),
            Column::Str(v) => {
                let mut cells = Vec::with_capacity(v.len());
                for (row, s) in v.iter().enumerate() {
                    cells.push(to_vlen(s).map_err(ctx(path, format!("{here}, row {row}")))?);
                }
                builder
                    .with_data(ArrayView1::from(cells.as_slice()))
                    .create(col_name.as_str())
            }
        };
        created.map_err(ctx(path, format!("{here}: cannot write dataset")))?;
    }
    Ok(())
}

/// A variable-length HDF5 string; HDF5 strings end at NUL, so text holding one is refused.
fn to_vlen(s: &str) -> Result<VarLenUnicode, String> {
    VarLenUnicode::from_str(s)
        .map_err(|_| "text contains a NUL character, which HDF5 strings cannot hold".to_string())
}

/// Reads every table under `/tables` of the HDF5 file `path`.
pub fn read(path: &Path) -> Result<BTreeMap<String, Table>, ArtefactError> {
    // No HDF5 file lock on reading: a child process forked by another thread while the file
    // was being written inherits its descriptor and lock for a moment, which made an immediate
    // read fail with EWOULDBLOCK; artefacts are written to a temporary file and renamed, so a
    // reader never sees a file being written and needs no lock.
    let file = File::with_options()
        .with_fapl(|p| p.file_locking(false))
        .open(path)
        .map_err(ctx(path, "not a readable HDF5 file"))?;
    let root = file.group(TABLES_GROUP).map_err(ctx(
        path,
        format!("no group `/{TABLES_GROUP}`; not a femu HDF5 artefact"),
    ))?;
    let names = root
        .member_names()
        .map_err(ctx(path, format!("cannot list group `/{TABLES_GROUP}`")))?;
    let mut tables = BTreeMap::new();
    for name in names {
        let group = root.group(&name).map_err(ctx(
            path,
            format!("table `{name}`: `/{TABLES_GROUP}/{name}` is not a readable group"),
        ))?;
        let table = read_table(&group, &name, path)?;
        tables.insert(name, table);
    }
    Ok(tables)
}

fn read_table(group: &Group, name: &str, path: &Path) -> Result<Table, ArtefactError> {
    let where_ = format!("table `{name}`");
    let members = group
        .member_names()
        .map_err(ctx(path, format!("{where_}: cannot list group")))?;
    let attrs = group
        .attr_names()
        .map_err(ctx(path, format!("{where_}: cannot list attributes")))?;
    let order = if attrs.iter().any(|a| a == COLUMN_ORDER) {
        let attr = group.attr(COLUMN_ORDER).map_err(ctx(
            path,
            format!("{where_}: cannot open attribute `{COLUMN_ORDER}`"),
        ))?;
        let shape = attr
            .get_shape()
            .map_err(ctx(path, format!("{where_}: attribute `{COLUMN_ORDER}`")))?;
        if shape.len() != 1 {
            return Err(decode(
                path,
                format!(
                    "{where_}: attribute `{COLUMN_ORDER}` must be a 1-D array of strings, found {} dimensions",
                    shape.len()
                ),
            ));
        }
        read_strings(
            &attr,
            path,
            &format!("{where_}: attribute `{COLUMN_ORDER}`"),
        )?
    } else {
        members.clone()
    };
    let mut listed = BTreeSet::new();
    for c in &order {
        if !listed.insert(c.as_str()) {
            return Err(decode(
                path,
                format!("{where_}: `{COLUMN_ORDER}` lists column `{c}` twice"),
            ));
        }
        if !members.contains(c) {
            return Err(decode(
                path,
                format!(
                    "{where_}: `{COLUMN_ORDER}` lists column `{c}` but the group has no such dataset"
                ),
            ));
        }
    }
    if let Some(extra) = members.iter().find(|m| !listed.contains(m.as_str())) {
        return Err(decode(
            path,
            format!("{where_}: dataset `{extra}` is not listed in `{COLUMN_ORDER}`"),
        ));
    }
    let mut table = Table::new();
    for c in order {
        let here = format!("{where_}, column `{c}`");
        let ds = group
            .dataset(&c)
            .map_err(ctx(path, format!("{here}: not a readable dataset")))?;
        let column = read_column(&ds, path, &here)?;
        if let Some((first, prev)) = table.columns.first()
            && prev.len() != column.len()
        {
            return Err(decode(
                path,
                format!(
                    "{here} has {} rows, column `{first}` has {}",
                    column.len(),
                    prev.len()
                ),
            ));
        }
        table.columns.push((c, column));
    }
    Ok(table)
}

fn read_column(ds: &Dataset, path: &Path, here: &str) -> Result<Column, ArtefactError> {
    let shape = ds.get_shape().map_err(ctx(path, here))?;
    if shape.len() != 1 {
        return Err(decode(
            path,
            format!("{here} has {} dimensions; {SUPPORTED}", shape.len()),
        ));
    }
    let dtype = ds.dtype().map_err(ctx(path, here))?;
    let desc = dtype.to_descriptor().map_err(|e| {
        decode(
            path,
            format!("{here} has an unsupported HDF5 type ({e}); {SUPPORTED}"),
        )
    })?;
    let column = match desc {
        TypeDescriptor::Float(_) => Column::F64(read_numbers::<f64>(ds, path, here)?),
        // 32-bit integers stay 32-bit (femu's matrix indices), so a round trip keeps the digest.
        TypeDescriptor::Integer(IntSize::U4) => Column::I32(read_numbers::<i32>(ds, path, here)?),
        TypeDescriptor::Integer(_)
        | TypeDescriptor::Unsigned(IntSize::U1 | IntSize::U2 | IntSize::U4) => {
            Column::I64(read_numbers::<i64>(ds, path, here)?)
        }
        TypeDescriptor::Unsigned(IntSize::U8) => {
            let raw = read_numbers::<u64>(ds, path, here)?;
            let mut out = Vec::with_capacity(raw.len());
            for (row, v) in raw.into_iter().enumerate() {
                out.push(i64::try_from(v).map_err(|_| {
                    decode(
                        path,
                        format!("{here}, row {row}: {v} does not fit in int64"),
                    )
                })?);
            }
            Column::I64(out)
        }
        TypeDescriptor::VarLenUnicode | TypeDescriptor::VarLenAscii => {
            Column::Str(read_strings(ds, path, here)?)
        }
        other => {
            return Err(decode(
                path,
                format!("{here} has HDF5 type {other}; {SUPPORTED}"),
            ));
        }
    };
    if column.len() != shape[0] {
        return Err(decode(
            path,
            format!(
                "{here}: read {} values, dataset has {}",
                column.len(),
                shape[0]
            ),
        ));
    }
    Ok(column)
}

/// Refuses element counts whose buffer could not even be sized (corrupt extents).
fn check_count<T>(n: usize, path: &Path, here: &str) -> Result<(), ArtefactError> {
    match n.checked_mul(std::mem::size_of::<T>()) {
        Some(bytes) if bytes <= isize::MAX as usize => Ok(()),
        _ => Err(decode(
            path,
            format!("{here}: implausible length {n}; the file is corrupt"),
        )),
    }
}

fn read_numbers<T: H5Type>(
    ds: &Container,
    path: &Path,
    here: &str,
) -> Result<Vec<T>, ArtefactError> {
    let n = ds.space().map_err(ctx(path, here))?.size();
    check_count::<T>(n, path, here)?;
    ds.read_raw::<T>()
        .map_err(ctx(path, format!("{here}: cannot read")))
}

/// Reads a 1-D dataset or attribute of variable-length strings, checking that each is UTF-8.
fn read_strings(c: &Container, path: &Path, here: &str) -> Result<Vec<String>, ArtefactError> {
    let desc = c
        .dtype()
        .and_then(|t| t.to_descriptor())
        .map_err(ctx(path, format!("{here}: unsupported type")))?;
    let n = c.space().map_err(ctx(path, here))?.size();
    let bytes: Vec<Vec<u8>> = match desc {
        TypeDescriptor::VarLenUnicode => {
            check_count::<VarLenUnicode>(n, path, here)?;
            let raw = c
                .read_raw::<VarLenUnicode>()
                .map_err(ctx(path, format!("{here}: cannot read")))?;
            raw.iter().map(|s| s.as_bytes().to_vec()).collect()
        }
        TypeDescriptor::VarLenAscii => {
            check_count::<VarLenAscii>(n, path, here)?;
            let raw = c
                .read_raw::<VarLenAscii>()
                .map_err(ctx(path, format!("{here}: cannot read")))?;
            raw.iter().map(|s| s.as_bytes().to_vec()).collect()
        }
        other => {
            return Err(decode(
                path,
                format!(
                    "{here} has HDF5 type {other}; expected variable-length (UTF-8 or ASCII) strings"
                ),
            ));
        }
    };
    bytes
        .into_iter()
        .enumerate()
        .map(|(row, b)| {
            String::from_utf8(b)
                .map_err(|e| decode(path, format!("{here}, row {row}: not UTF-8 ({e})")))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::artefact::codec::{HDF5_FILE, read_dir, write_dir};
    use crate::artefact::{ArtefactKind, Format, Storage};

    fn sample() -> Artefact {
        Artefact::new(ArtefactKind::Frf)
            .with_meta("quantity", "receptance".into())
            .with_table(
                "frf",
                Table::new()
                    .with("freq_hz", Column::F64(vec![0.0, 0.5, 1.0e300, -2.5e-310]))
                    .with("n", Column::I64(vec![1, -2, i64::MAX, i64::MIN]))
                    .with("i", Column::I32(vec![0, -1, i32::MAX, i32::MIN]))
                    .with(
                        "dof",
                        Column::Str(vec![
                            "1:ux".into(),
                            String::new(),
                            "Größe µ€".into(),
                            "4:rz".into(),
                        ]),
                    )
                    .with(
                        "a_last",
                        Column::F64(vec![f64::INFINITY, f64::NEG_INFINITY, 0.0, -0.0]),
                    ),
                Storage::Parquet,
            )
            .with_table(
                "empty",
                Table::new()
                    .with("z", Column::F64(vec![]))
                    .with("y", Column::I64(vec![]))
                    .with("x", Column::Str(vec![])),
                Storage::Ipc,
            )
            .with_table("no_columns", Table::new(), Storage::Ipc)
    }

    fn tables(a: &Artefact) -> BTreeMap<String, Table> {
        a.tables
            .iter()
            .map(|(k, v)| (k.clone(), v.0.clone()))
            .collect()
    }

    #[test]
    fn round_trip_keeps_all_column_types_order_and_empty_tables() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("data.h5");
        let a = sample();
        write(&a, &path).unwrap();
        let back = read(&path).unwrap();
        assert_eq!(back, tables(&a));
        let names: Vec<&str> = back["frf"].columns.iter().map(|c| c.0.as_str()).collect();
        assert_eq!(names, ["freq_hz", "n", "i", "dof", "a_last"]);
        assert_eq!(back["empty"].rows(), 0);
        assert_eq!(back["empty"].columns.len(), 3);
    }

    #[test]
    fn writing_twice_gives_identical_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let (p1, p2) = (dir.path().join("one.h5"), dir.path().join("two.h5"));
        write(&sample(), &p1).unwrap();
        std::thread::sleep(std::time::Duration::from_millis(1100));
        write(&sample(), &p2).unwrap();
        let (b1, b2) = (std::fs::read(&p1).unwrap(), std::fs::read(&p2).unwrap());
        assert!(!b1.is_empty());
        assert!(b1 == b2, "HDF5 files differ");
        // Writing over an existing file gives the same bytes too.
        write(&sample(), &p1).unwrap();
        assert!(
            std::fs::read(&p1).unwrap() == b2,
            "rewritten HDF5 file differs"
        );
    }

    #[test]
    fn non_hdf5_file_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("data.h5");
        std::fs::write(&path, b"this is not an HDF5 file").unwrap();
        let e = read(&path).unwrap_err();
        assert!(matches!(e, ArtefactError::Decode { .. }), "{e:?}");
        let e = e.to_string();
        assert!(
            e.contains(&path.display().to_string()) && e.contains("HDF5"),
            "{e}"
        );
        let missing = dir.path().join("missing.h5");
        let e = read(&missing).unwrap_err().to_string();
        assert!(e.contains("missing.h5"), "{e}");
    }

    #[test]
    fn foreign_files_are_read_or_refused_with_a_clear_message() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("foreign.h5");
        {
            let f = File::create(&path).unwrap();
            let t = f.create_group("tables/ok").unwrap();
            t.new_dataset_builder()
                .with_data(&[1.5f32, 2.5])
                .create("b_f32")
                .unwrap();
            t.new_dataset_builder()
                .with_data(&[7i32, -8])
                .create("a_i32")
                .unwrap();
            t.new_dataset_builder()
                .with_data(&[9u64, 10])
                .create("c_u64")
                .unwrap();
            let bad = f.create_group("tables/bad").unwrap();
            bad.new_dataset_builder()
                .with_data(&[true, false])
                .create("flag")
                .unwrap();
        }
        let e = read(&path).unwrap_err().to_string();
        assert!(
            e.contains("foreign.h5") && e.contains("table `bad`") && e.contains("column `flag`"),
            "{e}"
        );
        assert!(
            e.contains("float32/float64") && e.contains("strings"),
            "{e}"
        );
        {
            let f = File::open_rw(&path).unwrap();
            f.unlink("tables/bad").unwrap();
        }
        // Without `column_order` the columns come in name order.
        let t = read(&path).unwrap().remove("ok").unwrap();
        assert_eq!(
            t,
            Table::new()
                .with("a_i32", Column::I32(vec![7, -8]))
                .with("b_f32", Column::F64(vec![1.5, 2.5]))
                .with("c_u64", Column::I64(vec![9, 10]))
        );
        {
            let f = File::open_rw(&path).unwrap();
            let g = f.group("tables/ok").unwrap();
            g.new_dataset_builder()
                .with_data(ndarray::arr2(&[[1.0, 2.0], [3.0, 4.0]]).view())
                .create("d_2d")
                .unwrap();
        }
        let e = read(&path).unwrap_err().to_string();
        assert!(
            e.contains("column `d_2d`") && e.contains("2 dimensions"),
            "{e}"
        );
    }

    #[test]
    fn unstorable_names_and_text_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("data.h5");
        let a = Artefact::new(ArtefactKind::Frf).with_table(
            "t",
            Table::new().with("a/b", Column::I64(vec![1])),
            Storage::Ipc,
        );
        let e = write(&a, &path).unwrap_err().to_string();
        assert!(e.contains("`a/b`") && e.contains("data.h5"), "{e}");
        let a = Artefact::new(ArtefactKind::Frf).with_table(
            "t",
            Table::new().with("s", Column::Str(vec!["a\0b".into()])),
            Storage::Ipc,
        );
        let e = write(&a, &path).unwrap_err().to_string();
        assert!(
            e.contains("table `t`, column `s`, row 0") && e.contains("NUL"),
            "{e}"
        );
    }

    #[test]
    fn directory_round_trip_through_the_public_codec() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = sample();
        a.blobs
            .insert("plot.png".into(), vec![0x89, b'P', b'N', b'G']);
        let digest = write_dir(&a, dir.path(), Format::Hdf5, None).unwrap();
        assert!(dir.path().join(HDF5_FILE).exists());
        let b = read_dir(dir.path()).unwrap();
        assert_eq!(a, b);
        assert_eq!(digest, b.digest());
        assert_eq!(digest, a.digest());
    }

    /// A table whose columns differ in length (which one HDF5 file can hold, unlike an Arrow
    /// record batch) is refused on reading, naming the file, the table and the column.
    #[test]
    fn columns_of_unequal_length_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        write_dir(&sample(), dir.path(), Format::Hdf5, None).unwrap();
        {
            let f = File::open_rw(dir.path().join(HDF5_FILE)).unwrap();
            f.unlink("tables/frf/n").unwrap();
            f.group("tables/frf")
                .unwrap()
                .new_dataset_builder()
                .with_data(&[1i64, 2])
                .create("n")
                .unwrap();
        }
        let e = read_dir(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains(HDF5_FILE)
                && e.contains("table `frf`")
                && e.contains("column `n` has 2 rows"),
            "{e}"
        );
    }

    #[test]
    fn many_columns_exceeding_the_compact_attribute_limit_round_trip() {
        // 6000 names make `column_order` larger than the 64 KiB an old-style object header holds.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("wide.h5");
        let mut t = Table::new();
        for i in 0..6000 {
            t = t.with(
                format!("phi_{i:05}"),
                Column::F64(vec![i as f64, -(i as f64)]),
            );
        }
        let a = Artefact::new(ArtefactKind::Modes).with_table("shapes", t.clone(), Storage::Ipc);
        write(&a, &path).unwrap();
        assert_eq!(read(&path).unwrap()["shapes"], t);
    }
}
