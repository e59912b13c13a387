//! Artefact kinds as types: one file per kind, each one [`Kind`] implementation holding the
//! kind's name, schema version, published [`Layout`], writer and reader side by side.
//!
//! The layout is what `femu schema` publishes, what `femu show` and sweeps' `collect:` look
//! columns up in, and what [`check_layout`] holds every artefact to: no table, column, metadata
//! key or blob the layout does not declare, none it requires missing. The generic test in
//! `kinds/tests.rs` writes a representative value of every registered kind, reads it back and
//! checks the written artefact against the layout, so a writer, reader and layout that drift
//! apart fail it; the registry below is the one place a kind joins the engine, and a kind
//! missing from it (or from the test's examples) does not compile.
//!
//! | kind | file |
//! |---|---|
//! | `matrices` | [`matrices`] |
//! | `modes` | [`modes`] |
//! | `frf` | [`frf`] |
//! | `correlation` | [`correlation`] |
//! | `plot` | [`plot`] |
//! | `mesh` | [`mesh`] |
//! | `update_result` | [`update_result`] |
//! | `partition` | [`partition`] |
//! | `reduced_model` | [`reduced_model`] |
//! | `reduced_component` | [`reduced_component`] |
//! | `modal_correlation` | [`modal_correlation`] |
//! | `leverage` | [`leverage`] |
//! | `eigenvalue_sensitivity` | [`eigenvalue_sensitivity`] |
//! | `nastran_deck` | [`nastran_deck`] |
//! | `universal_file` | [`universal_file`] |
//! | `posterior` | [`posterior`] |
//! | `test_geometry` | [`test_geometry`] |
//! | `test_map` | [`test_map`] |
//! | `tmcmc_population` | [`tmcmc_population`] |

use super::{Artefact, ArtefactError, ArtefactKind, Column, Indices, Storage, Table};
use crate::core::DofId;
use crate::core::sparse::{
    INT32_INDEXED, LowerTriplets, SparseMatrix, TripletIndices, sparse_from_triplets,
};
use crate::sparse::IntegerIndex;
use faer::Mat;
use faer::sparse::{SparseColMat, SymbolicSparseColMat};

pub mod correlation;
pub mod eigenvalue_sensitivity;
pub mod frf;
pub mod leverage;
pub mod matrices;
pub mod mesh;
pub mod modal_correlation;
pub mod modes;
pub mod nastran_deck;
pub mod partition;
pub mod plot;
pub mod posterior;
pub mod reduced_component;
pub mod reduced_model;
pub mod test_geometry;
pub mod test_map;
#[cfg(test)]
mod tests;
pub mod tmcmc_population;
pub mod universal_file;
pub mod update_result;

pub use correlation::{CorrelationKind, correlation_from_artefact, correlation_to_artefact};
pub use frf::{FrfKind, frf_from_artefact, frf_to_artefact};
pub use matrices::{
    MatricesKind, linear_parameters_from_matrices, lower_matrices_to_artefact,
    matrices_from_artefact, matrices_to_artefact, pencil_from_matrices,
};
pub use modes::{ModesArtefact, ModesKind, modes_from_artefact, modes_to_artefact};
pub use plot::{Plot, PlotKind, plot_artefact};

/// An artefact kind as a type: its name and version, its layout, and the one writer and reader
/// of its values. `from_artefact(to_artefact(v))` gives `v` back (re-written, the same digest).
pub trait Kind {
    /// The kind's tag.
    const KIND: ArtefactKind;
    /// Its name in files, port declarations and schemas.
    const NAME: &'static str;
    /// Its schema version; bumped on any change of layout or meaning.
    const VERSION: u32 = 1;
    /// What an artefact of the kind holds.
    type Value;
    /// The published layout: tables and columns, metadata keys, blobs.
    fn layout() -> Layout;
    /// The value as an artefact.
    fn to_artefact(value: &Self::Value) -> Artefact;
    /// The value from an artefact of this kind.
    fn from_artefact(a: &Artefact) -> Result<Self::Value, ArtefactError>;
}

/// Registers every kind: the enum's list of kinds, names, versions and layouts come from here,
/// and a variant of [`ArtefactKind`] without an entry does not compile.
macro_rules! registry {
    ($($variant:ident => $ty:ty),+ $(,)?) => {
        impl ArtefactKind {
            /// All kinds, in registry order.
            pub const ALL: [ArtefactKind; [$(stringify!($variant)),+].len()] =
                [$(ArtefactKind::$variant),+];
        }

        /// The name of `kind`.
        pub(crate) fn name_of(kind: ArtefactKind) -> &'static str {
            match kind {
                $(ArtefactKind::$variant => <$ty as Kind>::NAME),+
            }
        }

        /// The schema version of `kind`.
        pub(crate) fn version_of(kind: ArtefactKind) -> u32 {
            match kind {
                $(ArtefactKind::$variant => <$ty as Kind>::VERSION),+
            }
        }

        /// The full layout of `kind`.
        pub fn kind_layout(kind: ArtefactKind) -> Layout {
            match kind {
                $(ArtefactKind::$variant => <$ty as Kind>::layout()),+
            }
        }

        /// Runs the generic round-trip and layout test for `kind`; every registered kind must
        /// have examples ([`tests::Example`]).
        #[cfg(test)]
        fn test_kind(kind: ArtefactKind) {
            match kind {
                $(ArtefactKind::$variant => tests::round_trip::<$ty>()),+
            }
        }

        /// That each registered type reports the tag it is registered under.
        #[cfg(test)]
        fn registered_tag(kind: ArtefactKind) -> ArtefactKind {
            match kind {
                $(ArtefactKind::$variant => <$ty as Kind>::KIND),+
            }
        }
    };
}

registry! {
    Matrices => matrices::MatricesKind,
    Modes => modes::ModesKind,
    Frf => frf::FrfKind,
    Correlation => correlation::CorrelationKind,
    Plot => plot::PlotKind,
    Mesh => mesh::MeshKind,
    UpdateResult => update_result::UpdateResultKind,
    Partition => partition::PartitionKind,
    ReducedModel => reduced_model::ReducedModelKind,
    ReducedComponent => reduced_component::ReducedComponentKind,
    ModalCorrelation => modal_correlation::ModalCorrelationKind,
    Leverage => leverage::LeverageKind,
    EigenvalueSensitivity => eigenvalue_sensitivity::EigenvalueSensitivityKind,
    NastranDeck => nastran_deck::NastranDeckKind,
    Posterior => posterior::PosteriorKind,
    TestGeometry => test_geometry::TestGeometryKind,
    TestMap => test_map::TestMapKind,
    UniversalFile => universal_file::UniversalFileKind,
    TmcmcPopulation => tmcmc_population::TmcmcPopulationKind,
}

// ---------------------------------------------------------------------------------------------
// Layouts

/// One column of a table layout.
#[derive(Clone, Debug)]
pub struct ColumnLayout {
    /// Column name (`phi_{r}` stands for `phi_1 … phi_m`).
    pub name: &'static str,
    /// `float64`, `int64` or `string`.
    pub dtype: &'static str,
    /// SI unit, or empty.
    pub unit: &'static str,
    /// What it holds.
    pub doc: &'static str,
}

/// One table of a kind's layout.
#[derive(Clone, Debug)]
pub struct TableLayout {
    /// Table name (`c{i}_T` stands for `c0_T`, `c1_T`, …).
    pub name: &'static str,
    /// `parquet` or `arrow_ipc`.
    pub storage: &'static str,
    /// Whether every artefact of the kind has it.
    pub required: bool,
    /// Columns in order.
    pub columns: Vec<ColumnLayout>,
}

/// One metadata key of a kind's layout.
#[derive(Clone, Debug)]
pub struct MetaLayout {
    /// The key.
    pub key: &'static str,
    /// Whether every artefact of the kind has it (optional keys are written by some stages or
    /// for some values only).
    pub required: bool,
    /// What it holds.
    pub doc: &'static str,
}

/// Everything an artefact of a kind may hold.
#[derive(Clone, Debug, Default)]
pub struct Layout {
    /// Tables, in publication order.
    pub tables: Vec<TableLayout>,
    /// Metadata keys.
    pub meta: Vec<MetaLayout>,
    /// Blob name patterns (`{name}.png`).
    pub blobs: Vec<&'static str>,
}

/// A column layout.
pub(crate) const fn col(
    name: &'static str,
    dtype: &'static str,
    unit: &'static str,
    doc: &'static str,
) -> ColumnLayout {
    ColumnLayout {
        name,
        dtype,
        unit,
        doc,
    }
}

/// A table layout.
pub(crate) fn table(
    name: &'static str,
    storage: Storage,
    required: bool,
    columns: Vec<ColumnLayout>,
) -> TableLayout {
    TableLayout {
        name,
        storage: storage_name(storage),
        required,
        columns,
    }
}

/// A required metadata key.
pub(crate) const fn meta(key: &'static str, doc: &'static str) -> MetaLayout {
    MetaLayout {
        key,
        required: true,
        doc,
    }
}

/// An optional metadata key.
pub(crate) const fn meta_opt(key: &'static str, doc: &'static str) -> MetaLayout {
    MetaLayout {
        key,
        required: false,
        doc,
    }
}

/// The `row, col, value` layout of a matrix table; `index` names what rows and columns index.
pub(crate) fn triplet_layout(
    name: &'static str,
    required: bool,
    index: &'static str,
    unit: &'static str,
    value_doc: &'static str,
) -> TableLayout {
    let (row, column) = match index {
        "dofs" => (
            "row index into `dofs` (int64 above 2^31 DOFs; int64 is also read)",
            "column index into `dofs` (as `row`)",
        ),
        _ => (
            "row index into `coords` (int64 above 2^31; int64 is also read)",
            "column index into `coords` (as `row`)",
        ),
    };
    table(
        name,
        Storage::Ipc,
        required,
        vec![
            col("row", "int32", "", row),
            col("col", "int32", "", column),
            col("value", "float64", unit, value_doc),
        ],
    )
}

/// The name of a storage in layouts and schemas.
pub fn storage_name(s: Storage) -> &'static str {
    match s {
        Storage::Parquet => "parquet",
        Storage::Ipc => "arrow_ipc",
    }
}

/// The tables and columns every artefact of `kind` has (the published schema).
pub fn layout(kind: ArtefactKind) -> Vec<TableLayout> {
    kind_layout(kind).tables
}

/// Whether `name` fits `pattern`, where one `{…}` in the pattern stands for a non-empty part.
pub fn name_matches(pattern: &str, name: &str) -> bool {
    match (pattern.find('{'), pattern.find('}')) {
        (Some(a), Some(b)) if a < b => {
            let (pre, post) = (&pattern[..a], &pattern[b + 1..]);
            name.len() > pre.len() + post.len() && name.starts_with(pre) && name.ends_with(post)
        }
        _ => pattern == name,
    }
}

/// Checks an artefact against its kind's layout exactly: required tables, metadata and blobs
/// present; every table, column, metadata key and blob declared; columns in order with their
/// types; tables in their storage.
pub fn check_layout(a: &Artefact) -> Result<(), ArtefactError> {
    let l = kind_layout(a.kind);
    let err = |m: String| Err(ArtefactError::schema(a.kind, m));
    for t in l.tables.iter().filter(|t| t.required) {
        if !a.tables.contains_key(t.name) {
            return err(format!("missing table `{}`", t.name));
        }
    }
    for (name, (table, storage)) in &a.tables {
        let declared = l
            .tables
            .iter()
            .find(|t| t.name == name)
            .or_else(|| l.tables.iter().find(|t| name_matches(t.name, name)));
        let Some(tl) = declared else {
            return err(format!("table `{name}` is not in the layout"));
        };
        if storage_name(*storage) != tl.storage {
            return err(format!(
                "table `{name}` is stored as {}, the layout says {}",
                storage_name(*storage),
                tl.storage
            ));
        }
        check_columns(a.kind, name, table, tl)?;
    }
    for m in l.meta.iter().filter(|m| m.required) {
        if !a.meta.contains_key(m.key) {
            return err(format!("missing metadata `{}`", m.key));
        }
    }
    for key in a.meta.keys() {
        if !l.meta.iter().any(|m| m.key == key) {
            return err(format!("metadata `{key}` is not in the layout"));
        }
    }
    for name in a.blobs.keys() {
        if !l.blobs.iter().any(|p| name_matches(p, name)) {
            return err(format!("blob `{name}` is not in the layout"));
        }
    }
    Ok(())
}

/// A table's columns against its layout: the same names in the same order with their types; a
/// repeated column `x_{r}` stands for `x_1, x_2, …` (none or more).
fn check_columns(
    kind: ArtefactKind,
    name: &str,
    table: &Table,
    tl: &TableLayout,
) -> Result<(), ArtefactError> {
    let mut cols = table.columns.iter().peekable();
    for cl in &tl.columns {
        let repeated = cl.name.strip_suffix("{r}");
        let mut k = 1;
        loop {
            let want = match repeated {
                Some(stem) => format!("{stem}{k}"),
                None => cl.name.to_string(),
            };
            let Some((got, c)) = cols.peek() else {
                if repeated.is_some() {
                    break;
                }
                return Err(ArtefactError::schema(
                    kind,
                    format!("table `{name}` lacks column `{}`", cl.name),
                ));
            };
            if *got != want {
                if repeated.is_some() {
                    break;
                }
                return Err(ArtefactError::schema(
                    kind,
                    format!("table `{name}`: column `{got}` where `{want}` belongs"),
                ));
            }
            if c.type_name() != cl.dtype {
                return Err(ArtefactError::schema(
                    kind,
                    format!(
                        "table `{name}`: column `{got}` is {}, the layout says {}",
                        c.type_name(),
                        cl.dtype
                    ),
                ));
            }
            cols.next();
            if repeated.is_none() {
                break;
            }
            k += 1;
        }
    }
    if let Some((extra, _)) = cols.next() {
        return Err(ArtefactError::schema(
            kind,
            format!("table `{name}`: column `{extra}` is not in the layout"),
        ));
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Shared pieces of writers and readers

/// Digest of a DOF list: artefacts that refer to the same DOFs record the same value.
pub fn dof_index_digest(dofs: &[DofId]) -> String {
    use rayon::prelude::*;
    use std::fmt::Write;
    /// DOFs per piece of text formatted on one thread.
    const PIECE: usize = 1 << 16;
    // The labels joined by newlines, formatted in pieces side by side and hashed in order.
    let pieces: Vec<String> = dofs
        .par_chunks(PIECE)
        .enumerate()
        .map(|(p, chunk)| {
            let mut text = String::with_capacity(chunk.len() * 12);
            for (i, d) in chunk.iter().enumerate() {
                if p > 0 || i > 0 {
                    text.push('\n');
                }
                write!(text, "{d}").expect("writing to a String cannot fail");
            }
            text
        })
        .collect();
    let mut hasher = crate::core::hashing::StreamHasher::new();
    for piece in &pieces {
        hasher.bytes(piece.as_bytes());
    }
    hasher.finish().to_hex().to_string()
}

/// A text column.
pub(crate) fn strs(v: impl IntoIterator<Item = String>) -> Column {
    Column::Str(v.into_iter().collect())
}

/// DOF labels as a text column.
pub(crate) fn dof_strs(dofs: &[DofId]) -> Column {
    use rayon::prelude::*;
    Column::Str(dofs.par_iter().map(|d| d.to_string()).collect())
}

/// DOF labels of column `column` of table `table`.
pub(crate) fn parse_dofs(
    kind: ArtefactKind,
    table: &str,
    labels: &[String],
) -> Result<Vec<DofId>, ArtefactError> {
    use rayon::prelude::*;
    // On all threads (a million labels at 10⁶ DOFs); a faulty label is then looked for in
    // order, so that the first is named.
    let parsed: Option<Vec<DofId>> = labels
        .par_iter()
        .with_min_len(4096)
        .map(|s| s.parse().ok())
        .collect();
    if let Some(dofs) = parsed {
        return Ok(dofs);
    }
    labels
        .iter()
        .enumerate()
        .map(|(row, s)| {
            s.parse::<DofId>()
                .map_err(|e| ArtefactError::schema(kind, format!("table `{table}` row {row}: {e}")))
        })
        .collect()
}

/// The `dof` column of table `table`.
pub(crate) fn dofs_table(a: &Artefact, table: &str) -> Result<Vec<DofId>, ArtefactError> {
    parse_dofs(a.kind, table, a.table(table)?.strs(table, "dof")?)
}

/// Checks an artefact's kind before reading it as `kind`.
pub(crate) fn expect_kind(a: &Artefact, kind: ArtefactKind) -> Result<(), ArtefactError> {
    if a.kind == kind {
        Ok(())
    } else {
        Err(ArtefactError::schema(
            kind,
            format!("got a `{}` artefact", a.kind),
        ))
    }
}

/// A metadata value of any deserialisable type (`null` when absent).
pub(crate) fn meta_value<T: serde::de::DeserializeOwned>(
    a: &Artefact,
    key: &str,
) -> Result<T, ArtefactError> {
    let v = a.meta.get(key).cloned().unwrap_or(serde_json::Value::Null);
    serde_json::from_value(v)
        .map_err(|e| ArtefactError::schema(a.kind, format!("metadata `{key}`: {e}")))
}

/// An optional metadata key's value, its default when absent.
pub(crate) fn optional_meta<T: serde::de::DeserializeOwned + Default>(
    a: &Artefact,
    key: &str,
) -> Result<T, ArtefactError> {
    if a.meta.contains_key(key) {
        meta_value(a, key)
    } else {
        Ok(T::default())
    }
}

/// The `row, col, value` table of a matrix with `dim` rows and columns (the larger), from its
/// entries as `(row, col)` indices and values: 32-bit indices when every index fits.
fn matrix_table(dim: usize, row: Vec<usize>, col: Vec<usize>, value: Vec<f64>) -> Table {
    let column = |v: Vec<usize>| {
        if dim <= INT32_INDEXED {
            Column::I32(v.into_iter().map(|i| i as i32).collect())
        } else {
            Column::I64(v.into_iter().map(|i| i as i64).collect())
        }
    };
    triplet_columns(column(row), column(col), value)
}

/// The `row, col, value` table of these columns.
fn triplet_columns(row: Column, col: Column, value: Vec<f64>) -> Table {
    Table::new()
        .with("row", row)
        .with("col", col)
        .with("value", Column::F64(value))
}

/// A sparse matrix as a `row, col, value` table (the layout of every matrix table), in
/// column-major order.
pub fn triplet_table(mat: &SparseMatrix) -> Table {
    let nnz = mat.compute_nnz();
    let (mut row, mut col, mut value) = (
        Vec::with_capacity(nnz),
        Vec::with_capacity(nnz),
        Vec::with_capacity(nnz),
    );
    for j in 0..mat.ncols() {
        let rows = mat.row_idx_of_col_raw(j);
        row.extend_from_slice(rows);
        col.extend(std::iter::repeat_n(j, rows.len()));
        value.extend_from_slice(mat.val_of_col(j));
    }
    matrix_table(mat.nrows().max(mat.ncols()), row, col, value)
}

/// The lower triangle (`row ≥ col`) of a symmetric matrix as a `row, col, value` table, in
/// column-major order: half the bytes of [`triplet_table`] to write, hash and read back. The
/// columns are filled in place on all threads (hundreds of megabytes at 10⁶ DOFs).
pub fn lower_triplet_table(mat: &SparseMatrix) -> Table {
    lower_table(LowerTriplets::of(mat))
}

/// The `row, col, value` table of a lower triangle's triplets, taking their columns as they are.
pub fn lower_table(lower: LowerTriplets) -> Table {
    let index = |i: TripletIndices| match i {
        TripletIndices::I32(v) => Column::I32(v),
        TripletIndices::I64(v) => Column::I64(v),
    };
    triplet_columns(index(lower.rows), index(lower.cols), lower.values)
}

/// The symmetric matrix whose lower triangle (diagonal included) is `lower`, with rows ascending
/// in each column (see [`mirror_entries`]).
pub(crate) fn mirror_lower(lower: &SparseMatrix) -> SparseMatrix {
    mirror_entries(lower.ncols(), || {
        (0..lower.ncols()).flat_map(move |j| {
            let rows = lower.row_idx_of_col_raw(j).iter();
            rows.zip(lower.val_of_col(j)).map(move |(&i, &v)| (i, j, v))
        })
    })
}

/// The symmetric matrix whose lower triangle (diagonal included) is a table in column-major
/// order with rows strictly ascending in each column (as [`lower_triplet_table`] writes),
/// mirrored straight from the table's columns: one counting pass that also checks the order, no
/// intermediate matrix. `None` for a table out of that order or with an entry above the
/// diagonal (read through the general path, which names the entry).
pub(crate) fn mirror_sorted_lower<I: IntegerIndex>(
    n: usize,
    rows: &[I],
    cols: &[I],
    vals: &[f64],
) -> Option<SparseMatrix> {
    if rows.len() != cols.len() || rows.len() != vals.len() {
        return None;
    }
    let mut previous = None;
    for (&r, &c) in rows.iter().zip(cols) {
        let (r, c) = next_in_column_order(n, r, c, &mut previous)?;
        if c > r {
            return None;
        }
    }
    // Every index was checked above: 0 ≤ c ≤ r < n.
    Some(mirror_entries(n, || {
        rows.iter()
            .zip(cols)
            .zip(vals)
            .map(|((&r, &c), &v)| (r.into() as usize, c.into() as usize, v))
    }))
}

/// The symmetric matrix of the lower-triangle entries `(row, col, value)` (`row ≥ col`, in
/// column-major order, rows ascending in each column, indices below `n`) that `entries` gives
/// afresh at each call: column `i` holds the mirrored entries `(j, i)`, `j < i`, then its own
/// rows `≥ i`, so its rows ascend. A counting pass and two filling passes, no sorting.
fn mirror_entries<I>(n: usize, entries: impl Fn() -> I) -> SparseMatrix
where
    I: Iterator<Item = (usize, usize, f64)>,
{
    let mut col_ptr = vec![0usize; n + 1];
    for (r, c, _) in entries() {
        col_ptr[c + 1] += 1;
        if r != c {
            col_ptr[r + 1] += 1;
        }
    }
    for j in 0..n {
        col_ptr[j + 1] += col_ptr[j];
    }
    let nnz = col_ptr[n];
    let (mut row_idx, mut values) = (vec![0usize; nnz], vec![0.0f64; nnz]);
    let mut next = col_ptr[..n].to_vec();
    for (r, c, v) in entries().filter(|(r, c, _)| r != c) {
        (row_idx[next[r]], values[next[r]]) = (c, v);
        next[r] += 1;
    }
    for (r, c, v) in entries() {
        (row_idx[next[c]], values[next[c]]) = (r, v);
        next[c] += 1;
    }
    let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    SparseColMat::new(symbolic, values)
}

/// Entry `(r, c)` of a table read in order as indices, when both lie in `0..n` and the entry
/// follows `previous` in column-major order with rows strictly ascending; `None` otherwise.
fn next_in_column_order<I: IntegerIndex>(
    n: usize,
    r: I,
    c: I,
    previous: &mut Option<(usize, usize)>,
) -> Option<(usize, usize)> {
    let (r, c) = (
        usize::try_from(r.into()).ok()?,
        usize::try_from(c.into()).ok()?,
    );
    if r >= n || c >= n || previous.is_some_and(|p| (c, r) <= p) {
        return None;
    }
    *previous = Some((c, r));
    Some((r, c))
}

/// The matrix of a table in column-major order with rows strictly ascending in each column (as
/// [`triplet_table`] writes every matrix femu builds), built without sorting; `None` for any
/// other table, which is then read through the general triplet path.
fn sorted_column_major<I: IntegerIndex>(
    n: usize,
    rows: &[I],
    cols: &[I],
    vals: &[f64],
) -> Option<SparseMatrix> {
    if rows.len() != cols.len() || rows.len() != vals.len() {
        return None;
    }
    let mut col_ptr = vec![0usize; n + 1];
    let mut previous = None;
    let mut row_idx = Vec::with_capacity(rows.len());
    for (&r, &c) in rows.iter().zip(cols) {
        let (r, c) = next_in_column_order(n, r, c, &mut previous)?;
        col_ptr[c + 1] += 1;
        row_idx.push(r);
    }
    for j in 0..n {
        col_ptr[j + 1] += col_ptr[j];
    }
    let symbolic = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
    Some(SparseColMat::new(symbolic, vals.to_vec()))
}

/// The sparse matrix table `name` of an artefact over `n` DOFs, if present.
pub(crate) fn read_sparse(
    a: &Artefact,
    name: &str,
    n: usize,
) -> Result<Option<SparseMatrix>, ArtefactError> {
    let Some((t, _)) = a.tables.get(name) else {
        return Ok(None);
    };
    let (r, c, v) = (
        t.indices(name, "row")?,
        t.indices(name, "col")?,
        t.f64s(name, "value")?,
    );
    let sorted = match (r, c) {
        (Indices::I32(r), Indices::I32(c)) => sorted_column_major(n, r, c, v),
        (r, c) => sorted_column_major(n, &r.to_i64(), &c.to_i64(), v),
    };
    if let Some(m) = sorted {
        return Ok(Some(m));
    }
    if r.len() != v.len() || c.len() != v.len() {
        return Err(ArtefactError::schema(
            a.kind,
            format!("table `{name}`: columns of unequal length"),
        ));
    }
    let index = |i: i64| usize::try_from(i).unwrap_or(usize::MAX);
    let trip: Vec<(usize, usize, f64)> = v
        .iter()
        .enumerate()
        .map(|(k, v)| (index(r.get(k)), index(c.get(k)), *v))
        .collect();
    sparse_from_triplets("matrix", n, &trip)
        .map(Some)
        .map_err(|e| ArtefactError::schema(a.kind, format!("table `{name}`: {e}")))
}

/// A dense matrix as a `row, col, value` table of its non-zero entries.
pub fn dense_triplet_table(m: &Mat<f64>) -> Table {
    let (mut r, mut c, mut v) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..m.ncols() {
        for i in 0..m.nrows() {
            if m[(i, j)] != 0.0 {
                r.push(i);
                c.push(j);
                v.push(m[(i, j)]);
            }
        }
    }
    matrix_table(m.nrows().max(m.ncols()), r, c, v)
}

/// The dense `rows × cols` matrix of triplet table `name`.
pub(crate) fn dense_from(
    a: &Artefact,
    name: &str,
    rows: usize,
    cols: usize,
) -> Result<Mat<f64>, ArtefactError> {
    let t = a.table(name)?;
    let (r, c, v) = (
        t.indices(name, "row")?,
        t.indices(name, "col")?,
        t.f64s(name, "value")?,
    );
    if r.len() != v.len() || c.len() != v.len() {
        return Err(ArtefactError::schema(
            a.kind,
            format!("table `{name}`: columns of unequal length"),
        ));
    }
    let mut m = Mat::zeros(rows, cols);
    for (k, value) in v.iter().enumerate() {
        let (i, j) = (r.get(k), c.get(k));
        if i < 0 || j < 0 || i as usize >= rows || j as usize >= cols {
            return Err(ArtefactError::schema(
                a.kind,
                format!("table `{name}` row {k}: entry ({i}, {j}) outside {rows}x{cols}"),
            ));
        }
        m[(i as usize, j as usize)] += value;
    }
    Ok(m)
}
