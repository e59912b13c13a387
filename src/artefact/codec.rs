//! Reading and writing artefact directories: `meta.json`, Parquet and Arrow IPC tables, blobs,
//! and (with the `hdf5` feature) a single HDF5 file.

use super::{Artefact, ArtefactError, ArtefactKind, Column, Format, Storage, Table};
use arrow_array::{
    Array, ArrayRef, Float32Array, Float64Array, Int32Array, Int64Array, LargeStringArray,
    RecordBatch, StringArray,
};
use arrow_schema::{DataType, Field, Schema};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::sync::Arc;

/// Name of the metadata file in every artefact directory.
pub const META_FILE: &str = "meta.json";

/// Writes `a` into the (existing, empty) directory `dir`. `producer` (stage kind and key) is
/// recorded in `meta.json` but is not part of the digest. Returns the digest.
pub fn write_dir(
    a: &Artefact,
    dir: &Path,
    format: Format,
    producer: Option<serde_json::Value>,
) -> Result<String, ArtefactError> {
    write_dir_hashed(a, dir, format, producer).map(|(digest, _)| digest)
}

/// [`write_dir`], also returning the blake3 hash of every file written, by file name, taken
/// from the bytes as they were written (so a cache entry's manifest needs no second read of
/// files of gigabytes). The tables are written side by side, and beside the content digest.
pub fn write_dir_hashed(
    a: &Artefact,
    dir: &Path,
    format: Format,
    producer: Option<serde_json::Value>,
) -> Result<(String, BTreeMap<String, String>), ArtefactError> {
    write_dir_with_digest(a, dir, format, producer, || a.digest())
}

/// [`write_dir_hashed`] for an artefact whose content digest `digest` ([`Artefact::digest`])
/// is already known: it is recorded, not computed again.
pub fn write_dir_digested(
    a: &Artefact,
    dir: &Path,
    format: Format,
    producer: Option<serde_json::Value>,
    digest: &str,
) -> Result<(String, BTreeMap<String, String>), ArtefactError> {
    write_dir_with_digest(a, dir, format, producer, || digest.to_string())
}

/// Writes `a` into `dir`, its digest given by `digest` (run beside the tables' writing).
fn write_dir_with_digest(
    a: &Artefact,
    dir: &Path,
    format: Format,
    producer: Option<serde_json::Value>,
    digest: impl FnOnce() -> String + Send,
) -> Result<(String, BTreeMap<String, String>), ArtefactError> {
    use rayon::prelude::*;
    for (name, (table, _)) in &a.tables {
        table.check_lengths(name)?;
    }
    // Each table's file hash by file name, and its entry in `meta.json` by table name.
    type Written = (
        BTreeMap<String, String>,
        serde_json::Map<String, serde_json::Value>,
    );
    let write_tables = || -> Result<Written, ArtefactError> {
        let (mut hashes, mut tables) = (BTreeMap::new(), serde_json::Map::new());
        match format {
            Format::Arrow => {
                let written: Vec<_> = a
                    .tables
                    .par_iter()
                    .map(|(name, (table, storage))| {
                        let file = match storage {
                            Storage::Parquet => format!("{name}.parquet"),
                            Storage::Ipc => format!("{name}.arrow"),
                        };
                        let path = dir.join(&file);
                        let hash = match storage {
                            Storage::Parquet => write_parquet(table, &path)?,
                            Storage::Ipc => write_ipc(table, &path)?,
                        };
                        let meta = table_meta(table, &file, *storage);
                        Ok((name, file, hash, meta))
                    })
                    .collect::<Result<_, ArtefactError>>()?;
                for (name, file, hash, meta) in written {
                    hashes.insert(file, hash);
                    tables.insert(name.clone(), meta);
                }
            }
            Format::Hdf5 => {
                let path = dir.join(HDF5_FILE);
                write_hdf5(a, &path)?;
                let hash =
                    super::digest::hash_file(&path).map_err(|e| ArtefactError::io(&path, e))?;
                hashes.insert(HDF5_FILE.to_string(), hash);
                for (name, (table, storage)) in &a.tables {
                    tables.insert(name.clone(), table_meta(table, HDF5_FILE, *storage));
                }
            }
        }
        Ok((hashes, tables))
    };
    let (digest, written) = rayon::join(digest, write_tables);
    let (mut hashes, tables) = written?;
    for (name, bytes) in &a.blobs {
        let path = dir.join(name);
        std::fs::write(&path, bytes).map_err(|e| ArtefactError::io(&path, e))?;
        hashes.insert(name.clone(), super::digest::hash_bytes(bytes));
    }
    let mut meta = serde_json::Map::new();
    meta.insert("femu_artefact".into(), a.kind.name().into());
    meta.insert("schema_version".into(), a.kind.schema_version().into());
    meta.insert(
        "format".into(),
        serde_json::to_value(format).expect("format serialises"),
    );
    meta.insert("digest".into(), digest.clone().into());
    meta.insert("meta".into(), serde_json::Value::Object(a.meta.clone()));
    meta.insert("tables".into(), serde_json::Value::Object(tables));
    meta.insert(
        "blobs".into(),
        a.blobs.keys().cloned().collect::<Vec<_>>().into(),
    );
    if let Some(p) = producer {
        meta.insert("producer".into(), p);
    }
    let path = dir.join(META_FILE);
    let text = serde_json::to_string_pretty(&serde_json::Value::Object(meta))
        .expect("meta serialises")
        + "\n";
    std::fs::write(&path, &text).map_err(|e| ArtefactError::io(&path, e))?;
    hashes.insert(
        META_FILE.to_string(),
        super::digest::hash_bytes(text.as_bytes()),
    );
    Ok((digest, hashes))
}

/// A writer that hashes (blake3) the bytes it passes on, as they are written.
struct HashingWriter<W> {
    inner: W,
    hasher: blake3::Hasher,
}

impl<W> HashingWriter<W> {
    fn new(inner: W) -> Self {
        Self {
            inner,
            hasher: blake3::Hasher::new(),
        }
    }

    /// The hex hash of everything written.
    fn hash(&self) -> String {
        self.hasher.finalize().to_hex().to_string()
    }
}

impl<W: std::io::Write> std::io::Write for HashingWriter<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hasher.update(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

fn table_meta(table: &Table, file: &str, storage: Storage) -> serde_json::Value {
    serde_json::json!({
        "file": file,
        "storage": match storage { Storage::Parquet => "parquet", Storage::Ipc => "arrow_ipc" },
        "rows": table.rows(),
        "columns": table.columns.iter().map(|(n, c)| serde_json::json!({"name": n, "type": c.type_name()})).collect::<Vec<_>>(),
    })
}

/// The parsed `meta.json` of an artefact directory.
#[derive(Clone, Debug)]
pub struct DirMeta {
    /// Kind.
    pub kind: ArtefactKind,
    /// Format on disk.
    pub format: Format,
    /// Recorded digest.
    pub digest: String,
    /// The whole JSON object.
    pub raw: serde_json::Map<String, serde_json::Value>,
}

/// Reads and checks `meta.json` in `dir`.
pub fn read_meta(dir: &Path) -> Result<DirMeta, ArtefactError> {
    let path = dir.join(META_FILE);
    let text = std::fs::read_to_string(&path).map_err(|e| ArtefactError::io(&path, e))?;
    let bad = |message: String| ArtefactError::Decode {
        path: path.clone(),
        message,
    };
    let raw: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
    let raw = raw
        .as_object()
        .cloned()
        .ok_or_else(|| bad("not a JSON object".into()))?;
    let kind_name = raw
        .get("femu_artefact")
        .and_then(|v| v.as_str())
        .ok_or_else(|| bad("no `femu_artefact` kind; is this a femu artefact directory?".into()))?;
    let kind = ArtefactKind::from_name(kind_name)
        .ok_or_else(|| bad(format!("unknown artefact kind `{kind_name}`")))?;
    let version = raw
        .get("schema_version")
        .and_then(|v| v.as_u64())
        .unwrap_or(0);
    if version != kind.schema_version() as u64 {
        return Err(bad(format!(
            "schema version {version} of `{kind}`; this femu reads version {}",
            kind.schema_version()
        )));
    }
    let format = raw
        .get("format")
        .cloned()
        .map(serde_json::from_value::<Format>)
        .transpose()
        .map_err(|e| bad(format!("bad `format`: {e}")))?
        .unwrap_or_default();
    let digest = raw
        .get("digest")
        .and_then(|v| v.as_str())
        .unwrap_or_default()
        .to_string();
    Ok(DirMeta {
        kind,
        format,
        digest,
        raw,
    })
}

/// Reads the artefact in `dir`.
pub fn read_dir(dir: &Path) -> Result<Artefact, ArtefactError> {
    let m = read_meta(dir)?;
    let meta_path = dir.join(META_FILE);
    let bad = |message: String| ArtefactError::Decode {
        path: meta_path.clone(),
        message,
    };
    let mut a = Artefact::new(m.kind);
    a.meta = m
        .raw
        .get("meta")
        .and_then(|v| v.as_object())
        .cloned()
        .unwrap_or_default();
    let tables = m
        .raw
        .get("tables")
        .and_then(|v| v.as_object())
        .cloned()
        .unwrap_or_default();
    let hdf5_tables = if m.format == Format::Hdf5 {
        let path = dir.join(HDF5_FILE);
        Some(read_hdf5(&path).map_err(|e| match e {
            // Name the file that could not be read.
            ArtefactError::Hdf5Unavailable => ArtefactError::Decode {
                path: path.clone(),
                message: e.to_string(),
            },
            e => e,
        })?)
    } else {
        None
    };
    for (name, t) in &tables {
        let storage = match t.get("storage").and_then(|v| v.as_str()) {
            Some("parquet") => Storage::Parquet,
            Some("arrow_ipc") => Storage::Ipc,
            other => return Err(bad(format!("table `{name}`: unknown storage {other:?}"))),
        };
        let (table, source) = match &hdf5_tables {
            Some(h) => (
                h.get(name)
                    .cloned()
                    .ok_or_else(|| bad(format!("table `{name}` is missing from {HDF5_FILE}")))?,
                dir.join(HDF5_FILE),
            ),
            None => {
                let file = t
                    .get("file")
                    .and_then(|v| v.as_str())
                    .ok_or_else(|| bad(format!("table `{name}` names no file")))?;
                if file.contains('/') || file.contains("..") {
                    return Err(bad(format!(
                        "table `{name}`: file `{file}` must be a plain name in the artefact directory"
                    )));
                }
                let path = dir.join(file);
                let table = match storage {
                    Storage::Parquet => read_parquet(&path)?,
                    Storage::Ipc => read_ipc(&path)?,
                };
                (table, path)
            }
        };
        // Readers may index one column by another's rows: a file whose columns differ in
        // length (a hostile HDF5 file can hold that) is refused here, naming file and table.
        table
            .check_lengths(name)
            .map_err(|e| ArtefactError::Decode {
                path: source,
                message: e.to_string(),
            })?;
        a.tables.insert(name.clone(), (table, storage));
    }
    if let Some(blobs) = m.raw.get("blobs").and_then(|v| v.as_array()) {
        for b in blobs {
            let name = b
                .as_str()
                .ok_or_else(|| bad("`blobs` must list file names".into()))?;
            if name.contains('/') || name.contains("..") {
                return Err(bad(format!("blob `{name}` must be a plain name")));
            }
            let path = dir.join(name);
            let bytes = std::fs::read(&path).map_err(|e| ArtefactError::io(&path, e))?;
            a.blobs.insert(name.to_string(), bytes);
        }
    }
    Ok(a)
}

fn to_batch(table: &Table) -> Result<RecordBatch, ArtefactError> {
    let mut fields = Vec::new();
    let mut arrays: Vec<ArrayRef> = Vec::new();
    for (name, col) in &table.columns {
        let (dt, arr) = column_array(col, 0, col.len());
        fields.push(Field::new(name, dt, false));
        arrays.push(arr);
    }
    batch_of(fields, arrays)
}

/// Rows `start..end` of a table whose columns all have at least `end` rows, as a record batch.
fn to_batch_rows(table: &Table, start: usize, end: usize) -> Result<RecordBatch, ArtefactError> {
    let mut fields = Vec::new();
    let mut arrays: Vec<ArrayRef> = Vec::new();
    for (name, col) in &table.columns {
        let (dt, arr) = column_array(col, start, end);
        fields.push(Field::new(name, dt, false));
        arrays.push(arr);
    }
    batch_of(fields, arrays)
}

/// Rows `start..end` of a column as an Arrow array.
fn column_array(col: &Column, start: usize, end: usize) -> (DataType, ArrayRef) {
    match col {
        Column::F64(v) => (
            DataType::Float64,
            Arc::new(Float64Array::from(v[start..end].to_vec())),
        ),
        Column::I64(v) => (
            DataType::Int64,
            Arc::new(Int64Array::from(v[start..end].to_vec())),
        ),
        Column::I32(v) => (
            DataType::Int32,
            Arc::new(Int32Array::from(v[start..end].to_vec())),
        ),
        Column::Str(v) => (
            DataType::Utf8,
            Arc::new(StringArray::from(v[start..end].to_vec())),
        ),
    }
}

/// The record batch of these columns (an empty one without columns).
fn batch_of(fields: Vec<Field>, arrays: Vec<ArrayRef>) -> Result<RecordBatch, ArtefactError> {
    let schema = Arc::new(Schema::new(fields));
    if arrays.is_empty() {
        return Ok(RecordBatch::new_empty(schema));
    }
    RecordBatch::try_new(schema, arrays).map_err(|e| ArtefactError::Decode {
        path: "<table>".into(),
        message: e.to_string(),
    })
}

fn append_batch(table: &mut Table, batch: &RecordBatch, path: &Path) -> Result<(), ArtefactError> {
    let schema = batch.schema();
    let first = table.columns.is_empty();
    for (i, field) in schema.fields().iter().enumerate() {
        let arr = batch.column(i);
        let bad = || ArtefactError::Decode {
            path: path.to_path_buf(),
            message: format!(
                "column `{}` has type {}; femu reads float64/float32, int64/int32 and utf8 columns",
                field.name(),
                field.data_type()
            ),
        };
        if arr.null_count() > 0 {
            return Err(ArtefactError::Decode {
                path: path.to_path_buf(),
                message: format!(
                    "column `{}` holds {} null values; nulls are not allowed",
                    field.name(),
                    arr.null_count()
                ),
            });
        }
        let col = match field.data_type() {
            DataType::Float64 => Column::F64(
                arr.as_any()
                    .downcast_ref::<Float64Array>()
                    .ok_or_else(bad)?
                    .values()
                    .to_vec(),
            ),
            DataType::Float32 => Column::F64(
                arr.as_any()
                    .downcast_ref::<Float32Array>()
                    .ok_or_else(bad)?
                    .values()
                    .iter()
                    .map(|v| *v as f64)
                    .collect(),
            ),
            DataType::Int64 => Column::I64(
                arr.as_any()
                    .downcast_ref::<Int64Array>()
                    .ok_or_else(bad)?
                    .values()
                    .to_vec(),
            ),
            DataType::Int32 => Column::I32(
                arr.as_any()
                    .downcast_ref::<Int32Array>()
                    .ok_or_else(bad)?
                    .values()
                    .to_vec(),
            ),
            DataType::Utf8 => Column::Str(
                arr.as_any()
                    .downcast_ref::<StringArray>()
                    .ok_or_else(bad)?
                    .iter()
                    .map(|s| s.unwrap_or_default().to_string())
                    .collect(),
            ),
            DataType::LargeUtf8 => Column::Str(
                arr.as_any()
                    .downcast_ref::<LargeStringArray>()
                    .ok_or_else(bad)?
                    .iter()
                    .map(|s| s.unwrap_or_default().to_string())
                    .collect(),
            ),
            _ => return Err(bad()),
        };
        if first {
            table.columns.push((field.name().clone(), col));
        } else {
            match (&mut table.columns[i].1, col) {
                (Column::F64(a), Column::F64(b)) => a.extend(b),
                (Column::I64(a), Column::I64(b)) => a.extend(b),
                (Column::I32(a), Column::I32(b)) => a.extend(b),
                (Column::Str(a), Column::Str(b)) => a.extend(b),
                _ => return Err(bad()),
            }
        }
    }
    Ok(())
}

/// Writes a table as Parquet (zstd); returns the file's blake3 hash.
pub fn write_parquet(table: &Table, path: &Path) -> Result<String, ArtefactError> {
    use parquet::arrow::ArrowWriter;
    use parquet::basic::{Compression, ZstdLevel};
    use parquet::file::properties::WriterProperties;
    let batch = to_batch(table)?;
    let file = File::create(path).map_err(|e| ArtefactError::io(path, e))?;
    let props = WriterProperties::builder()
        .set_compression(Compression::ZSTD(ZstdLevel::default()))
        .build();
    let enc = |e: parquet::errors::ParquetError| ArtefactError::Decode {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut w = ArrowWriter::try_new(
        BufWriter::new(HashingWriter::new(file)),
        batch.schema(),
        Some(props),
    )
    .map_err(enc)?;
    w.write(&batch).map_err(enc)?;
    let hashed = w
        .into_inner()
        .map_err(enc)?
        .into_inner()
        .map_err(|e| ArtefactError::io(path, e.into_error()))?;
    Ok(hashed.hash())
}

/// Reads a Parquet file into a table. Hostile bytes give an error naming the file, never a
/// panic (see [`guard_decoder`]).
pub fn read_parquet(path: &Path) -> Result<Table, ArtefactError> {
    guard_decoder(path, "Parquet", || read_parquet_unguarded(path))
}

/// Runs a third-party decoder on `path`, turning a panic into a decode error naming the file.
///
/// The Parquet and Arrow IPC readers validate most of what they read, but a file crafted to
/// contradict itself (offsets past a buffer, a schema that disagrees with its data) can still
/// reach an `unwrap` or an index inside arrow/parquet. A cache entry or an `--out` tree is user
/// input, so such a panic is caught here, at the boundary, and reported as corruption.
fn guard_decoder<T>(
    path: &Path,
    what: &str,
    read: impl FnOnce() -> Result<T, ArtefactError>,
) -> Result<T, ArtefactError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(read)).unwrap_or_else(|panic| {
        let detail = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "no message".into());
        Err(ArtefactError::Decode {
            path: path.to_path_buf(),
            message: format!(
                "not a readable {what} file: its reader failed on malformed data ({detail})"
            ),
        })
    })
}

fn read_parquet_unguarded(path: &Path) -> Result<Table, ArtefactError> {
    use parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder;
    let file = File::open(path).map_err(|e| ArtefactError::io(path, e))?;
    let dec = |m: String| ArtefactError::Decode {
        path: path.to_path_buf(),
        message: m,
    };
    let builder = ParquetRecordBatchReaderBuilder::try_new(file)
        .map_err(|e| dec(format!("not a readable Parquet file: {e}")))?
        .with_batch_size(65536);
    let schema = builder.schema().clone();
    let reader = builder.build().map_err(|e| dec(e.to_string()))?;
    let mut table = Table::new();
    for batch in reader {
        let batch = batch.map_err(|e| dec(e.to_string()))?;
        append_batch(&mut table, &batch, path)?;
    }
    if table.columns.is_empty() {
        // A table with zero rows still has its columns.
        append_batch(&mut table, &RecordBatch::new_empty(schema), path)?;
    }
    Ok(table)
}

/// Writes a table as an Arrow IPC file; returns the file's blake3 hash.
pub fn write_ipc(table: &Table, path: &Path) -> Result<String, ArtefactError> {
    let file = File::create(path).map_err(|e| ArtefactError::io(path, e))?;
    let enc = |e: arrow_schema::ArrowError| ArtefactError::Decode {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    // Record batches of at most IPC_BATCH_ROWS rows: a matrix table of 10⁸ entries is then
    // copied into Arrow's buffers a few megabytes at a time, not whole beside itself. Columns
    // of unequal length are refused by `to_batch` as a whole.
    let rows = table.rows();
    let even = table.columns.iter().all(|(_, c)| c.len() == rows);
    let batch_rows = |start: usize| {
        if even {
            let end = (start + IPC_BATCH_ROWS).min(rows);
            to_batch_rows(table, start, end).map(|b| (b, end))
        } else {
            to_batch(table).map(|b| (b, rows))
        }
    };
    let (first, mut start) = batch_rows(0)?;
    let sink = BufWriter::new(HashingWriter::new(file));
    let mut writer = arrow_ipc::writer::FileWriter::try_new(sink, &first.schema()).map_err(enc)?;
    writer.write(&first).map_err(enc)?;
    while start < rows {
        let (batch, end) = batch_rows(start)?;
        writer.write(&batch).map_err(enc)?;
        start = end;
    }
    writer.finish().map_err(enc)?;
    let hashed = writer
        .into_inner()
        .map_err(enc)?
        .into_inner()
        .map_err(|e| ArtefactError::io(path, e.into_error()))?;
    Ok(hashed.hash())
}

/// Most rows in one record batch of an Arrow IPC file femu writes.
const IPC_BATCH_ROWS: usize = 1 << 20;

/// Reads an Arrow IPC file into a table. Hostile bytes give an error naming the file, never a
/// panic (see [`guard_decoder`]).
pub fn read_ipc(path: &Path) -> Result<Table, ArtefactError> {
    guard_decoder(path, "Arrow IPC", || read_ipc_unguarded(path))
}

fn read_ipc_unguarded(path: &Path) -> Result<Table, ArtefactError> {
    let file = File::open(path).map_err(|e| ArtefactError::io(path, e))?;
    let dec = |m: String| ArtefactError::Decode {
        path: path.to_path_buf(),
        message: m,
    };
    let reader = arrow_ipc::reader::FileReader::try_new(std::io::BufReader::new(file), None)
        .map_err(|e| dec(format!("not a readable Arrow IPC file: {e}")))?;
    let mut table = Table::new();
    let schema = reader.schema();
    for batch in reader {
        let batch = batch.map_err(|e| dec(e.to_string()))?;
        append_batch(&mut table, &batch, path)?;
    }
    if table.columns.is_empty() {
        // A table with zero rows still has its columns.
        append_batch(&mut table, &RecordBatch::new_empty(schema), path)?;
    }
    Ok(table)
}

/// File name of the single HDF5 file of an artefact in `hdf5` format.
pub const HDF5_FILE: &str = "data.h5";

#[cfg(feature = "hdf5")]
fn write_hdf5(a: &Artefact, path: &Path) -> Result<(), ArtefactError> {
    super::hdf5_codec::write(a, path)
}

#[cfg(feature = "hdf5")]
fn read_hdf5(path: &Path) -> Result<BTreeMap<String, Table>, ArtefactError> {
    super::hdf5_codec::read(path)
}

#[cfg(not(feature = "hdf5"))]
fn write_hdf5(_: &Artefact, _: &Path) -> Result<(), ArtefactError> {
    Err(ArtefactError::Hdf5Unavailable)
}

#[cfg(not(feature = "hdf5"))]
fn read_hdf5(_: &Path) -> Result<BTreeMap<String, Table>, ArtefactError> {
    Err(ArtefactError::Hdf5Unavailable)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Artefact {
        Artefact::new(ArtefactKind::Frf)
            .with_meta("quantity", "receptance".into())
            .with_table(
                "frf",
                Table::new()
                    .with("freq_hz", Column::F64(vec![0.0, 0.5, 1.0]))
                    .with("n", Column::I64(vec![1, -2, 3]))
                    .with("i", Column::I32(vec![i32::MIN, 0, i32::MAX]))
                    .with(
                        "dof",
                        Column::Str(vec!["1:ux".into(), "2:uy".into(), "3:rz".into()]),
                    ),
                Storage::Parquet,
            )
            .with_table(
                "shapes",
                Table::new()
                    .with("phi_1", Column::F64(vec![1.5, -0.25]))
                    .with("row", Column::I32(vec![7, -8])),
                Storage::Ipc,
            )
    }

    /// The hashes taken while writing are those of the files on disk, one for every file,
    /// whatever the storage (Parquet, Arrow IPC with several record batches, blob, meta).
    #[test]
    fn hashes_taken_while_writing_match_the_files() {
        let dir = tempfile::tempdir().unwrap();
        let rows = IPC_BATCH_ROWS + 3;
        let mut a = sample().with_table(
            "long",
            Table::new().with("x", Column::F64((0..rows).map(|i| i as f64).collect())),
            Storage::Ipc,
        );
        a.blobs.insert("plot.svg".into(), b"<svg/>".to_vec());
        let (digest, hashes) = write_dir_hashed(&a, dir.path(), Format::Arrow, None).unwrap();
        assert_eq!(digest, a.digest());
        let mut on_disk = BTreeMap::new();
        for e in std::fs::read_dir(dir.path()).unwrap() {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().to_string();
            on_disk.insert(name, crate::artefact::digest::hash_file(&path).unwrap());
        }
        assert_eq!(on_disk.len(), 5, "{on_disk:?}");
        assert_eq!(hashes, on_disk);
        let back = read_dir(dir.path()).unwrap();
        assert_eq!(back.digest(), digest);
    }

    #[test]
    fn round_trip_keeps_content_and_digest() {
        let dir = tempfile::tempdir().unwrap();
        let a = sample();
        let d = write_dir(&a, dir.path(), Format::Arrow, None).unwrap();
        let b = read_dir(dir.path()).unwrap();
        assert_eq!(a, b);
        assert_eq!(d, b.digest());
        assert!(
            dir.path().join("frf.parquet").exists() && dir.path().join("shapes.arrow").exists()
        );
    }

    #[test]
    fn writing_twice_gives_identical_bytes() {
        let (d1, d2) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        write_dir(&sample(), d1.path(), Format::Arrow, None).unwrap();
        write_dir(&sample(), d2.path(), Format::Arrow, None).unwrap();
        for f in ["frf.parquet", "shapes.arrow", "meta.json"] {
            assert_eq!(
                std::fs::read(d1.path().join(f)).unwrap(),
                std::fs::read(d2.path().join(f)).unwrap(),
                "{f}"
            );
        }
    }

    #[test]
    fn garbage_file_is_a_decode_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        write_dir(&sample(), dir.path(), Format::Arrow, None).unwrap();
        std::fs::write(dir.path().join("frf.parquet"), b"not parquet").unwrap();
        let e = read_dir(dir.path()).unwrap_err().to_string();
        assert!(e.contains("frf.parquet"), "{e}");
    }

    /// Bounded fuzzing of the readers: arbitrary bytes, and valid files with bytes overwritten,
    /// cut short or spliced, never panic; every failure is an error naming the file.
    mod fuzz {
        use super::*;
        use proptest::prelude::*;
        use proptest::sample::Index;

        /// The sample's files, written once: name → bytes.
        fn valid_files() -> &'static BTreeMap<String, Vec<u8>> {
            static FILES: std::sync::OnceLock<BTreeMap<String, Vec<u8>>> =
                std::sync::OnceLock::new();
            FILES.get_or_init(|| {
                let dir = tempfile::tempdir().unwrap();
                write_dir(&sample(), dir.path(), Format::Arrow, None).unwrap();
                ["frf.parquet", "shapes.arrow", "meta.json"]
                    .into_iter()
                    .map(|f| (f.to_string(), std::fs::read(dir.path().join(f)).unwrap()))
                    .collect()
            })
        }

        /// How a valid file is damaged.
        #[derive(Debug, Clone)]
        struct Damage {
            /// Bytes overwritten, at positions anywhere or within the last 512 bytes (where
            /// Parquet and Arrow IPC keep their footers).
            writes: Vec<(Index, u8, bool)>,
            /// Cut the file to this fraction of its length.
            cut: Option<Index>,
            /// Insert these bytes at a position.
            splice: Option<(Index, Vec<u8>)>,
        }

        fn damage() -> impl Strategy<Value = Damage> {
            (
                prop::collection::vec((any::<Index>(), any::<u8>(), any::<bool>()), 0..12),
                prop::option::of(any::<Index>()),
                prop::option::of((any::<Index>(), prop::collection::vec(any::<u8>(), 1..64))),
            )
                .prop_map(|(writes, cut, splice)| Damage {
                    writes,
                    cut,
                    splice,
                })
        }

        fn apply(bytes: &[u8], d: &Damage) -> Vec<u8> {
            let mut b = bytes.to_vec();
            for (at, v, tail) in &d.writes {
                let n = b.len();
                if n == 0 {
                    break;
                }
                let i = if *tail && n > 512 {
                    n - 512 + at.index(512)
                } else {
                    at.index(n)
                };
                b[i] = *v;
            }
            if let Some((at, extra)) = &d.splice {
                let i = at.index(b.len() + 1);
                b.splice(i..i, extra.iter().copied());
            }
            if let Some(cut) = &d.cut {
                b.truncate(cut.index(b.len() + 1));
            }
            b
        }

        /// Reads `file` of `dir` with the reader for its name; an error must name the file (for a
        /// damaged `meta.json`, a file of the directory: it may now name another table file).
        fn read_names_file(dir: &Path, file: &str) -> Result<(), String> {
            let path = dir.join(file);
            let (err, named) = match file {
                "frf.parquet" => (read_parquet(&path).err(), path.clone()),
                "shapes.arrow" => (read_ipc(&path).err(), path.clone()),
                _ => (read_dir(dir).err(), dir.to_path_buf()),
            };
            match err {
                Some(e) if !e.to_string().contains(&named.display().to_string()) => {
                    Err(format!("the error does not name {}: {e}", named.display()))
                }
                _ => Ok(()),
            }
        }

        fn config() -> ProptestConfig {
            ProptestConfig {
                cases: 300,
                failure_persistence: None,
                ..ProptestConfig::default()
            }
        }

        proptest! {
            #![proptest_config(config())]

            #[test]
            fn arbitrary_bytes_are_an_error_naming_the_file(
                which in 0usize..3,
                bytes in prop::collection::vec(any::<u8>(), 0..2048),
                magic in any::<bool>(),
            ) {
                let dir = tempfile::tempdir().unwrap();
                write_dir(&sample(), dir.path(), Format::Arrow, None).unwrap();
                let file = ["frf.parquet", "shapes.arrow", "meta.json"][which];
                let mut b = bytes;
                if magic && which == 0 {
                    // Parquet's magic at both ends, so the footer parser runs on the rest.
                    b.splice(0..0, *b"PAR1");
                    b.extend_from_slice(b"PAR1");
                }
                if magic && which == 1 {
                    b.splice(0..0, *b"ARROW1\0\0");
                    b.extend_from_slice(b"ARROW1");
                }
                std::fs::write(dir.path().join(file), &b).unwrap();
                let r = read_names_file(dir.path(), file);
                prop_assert!(r.is_ok(), "{}", r.unwrap_err());
            }

            #[test]
            fn damaged_files_are_an_error_naming_the_file(which in 0usize..3, d in damage()) {
                let dir = tempfile::tempdir().unwrap();
                write_dir(&sample(), dir.path(), Format::Arrow, None).unwrap();
                let file = ["frf.parquet", "shapes.arrow", "meta.json"][which];
                std::fs::write(dir.path().join(file), apply(&valid_files()[file], &d)).unwrap();
                let r = read_names_file(dir.path(), file);
                prop_assert!(r.is_ok(), "{}", r.unwrap_err());
            }

            /// `meta.json` that is valid JSON but says anything: other kinds and versions, tables
            /// naming odd files and storages, blobs that are not names.
            #[test]
            fn hostile_meta_json_is_an_error_naming_the_directory(
                kind in prop::sample::select(vec!["frf", "modes", "nope", ""]),
                version in prop::sample::select(vec![serde_json::json!(1), serde_json::json!(2), serde_json::json!("1"), serde_json::Value::Null]),
                format in prop::sample::select(vec![serde_json::json!("arrow"), serde_json::json!("hdf5"), serde_json::json!(7)]),
                file in prop::sample::select(vec!["frf.parquet", "shapes.arrow", "meta.json", "", ".", "..", "../frf.parquet", "/etc/passwd", "missing.parquet"]),
                storage in prop::sample::select(vec!["parquet", "arrow_ipc", "csv"]),
                blob in prop::sample::select(vec![serde_json::json!(["meta.json"]), serde_json::json!(["../x"]), serde_json::json!([1]), serde_json::json!("x"), serde_json::json!(["nope.png"])]),
            ) {
                let dir = tempfile::tempdir().unwrap();
                write_dir(&sample(), dir.path(), Format::Arrow, None).unwrap();
                let meta = serde_json::json!({
                    "femu_artefact": kind,
                    "schema_version": version,
                    "format": format,
                    "tables": {"t": {"file": file, "storage": storage}},
                    "blobs": blob,
                });
                std::fs::write(dir.path().join(META_FILE), meta.to_string()).unwrap();
                if let Err(e) = read_dir(dir.path()) {
                    let text = e.to_string();
                    prop_assert!(
                        text.contains(&dir.path().display().to_string()),
                        "the error does not name a file of the directory: {}", text
                    );
                }
            }
        }
    }
}
