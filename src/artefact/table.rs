//! Column tables: the in-memory form every artefact is made of, whatever the file format.

use std::fmt;

/// One typed column.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// 64-bit floats.
    F64(Vec<f64>),
    /// 64-bit integers.
    I64(Vec<i64>),
    /// 32-bit integers (the row and column indices of matrix tables: half the bytes of
    /// [`Column::I64`] to write, hash and read back).
    I32(Vec<i32>),
    /// UTF-8 text.
    Str(Vec<String>),
}

impl Column {
    /// Number of rows.
    pub fn len(&self) -> usize {
        match self {
            Column::F64(v) => v.len(),
            Column::I64(v) => v.len(),
            Column::I32(v) => v.len(),
            Column::Str(v) => v.len(),
        }
    }

    /// True when the column has no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Type name as shown to users.
    pub fn type_name(&self) -> &'static str {
        match self {
            Column::F64(_) => "float64",
            Column::I64(_) => "int64",
            Column::I32(_) => "int32",
            Column::Str(_) => "string",
        }
    }

    /// The column as indices, when it holds integers of either width.
    pub fn integers(&self) -> Option<Indices<'_>> {
        match self {
            Column::I32(v) => Some(Indices::I32(v)),
            Column::I64(v) => Some(Indices::I64(v)),
            _ => None,
        }
    }

    /// The value at `row` as text (for previews).
    pub fn cell(&self, row: usize) -> String {
        match self {
            Column::F64(v) => format!("{:.6e}", v[row]),
            Column::I64(v) => v[row].to_string(),
            Column::I32(v) => v[row].to_string(),
            Column::Str(v) => v[row].clone(),
        }
    }
}

/// Where a table is stored when the artefact format is the default one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Storage {
    /// A Parquet file (row tables: FRFs, correlation curves, histories).
    Parquet,
    /// An Arrow IPC file (matrices, mode shapes, large blocks).
    Ipc,
}

/// A table: named columns of equal length.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Table {
    /// Columns in order.
    pub columns: Vec<(String, Column)>,
}

/// A column is missing or has the wrong type.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("table `{table}`: {problem}")]
pub struct TableError {
    /// Table name.
    pub table: String,
    /// What is wrong.
    pub problem: String,
}

impl Table {
    /// An empty table.
    pub fn new() -> Self {
        Table::default()
    }

    /// Adds a column (builder style).
    pub fn with(mut self, name: impl Into<String>, column: Column) -> Self {
        self.columns.push((name.into(), column));
        self
    }

    /// Row count (of the first column).
    pub fn rows(&self) -> usize {
        self.columns.first().map(|c| c.1.len()).unwrap_or(0)
    }

    /// A column by name.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|c| c.0 == name).map(|c| &c.1)
    }

    /// Checks that every column has the same length.
    pub fn check_lengths(&self, table: &str) -> Result<(), TableError> {
        let n = self.rows();
        for (name, c) in &self.columns {
            if c.len() != n {
                return Err(TableError {
                    table: table.into(),
                    problem: format!("column `{name}` has {} rows, expected {n}", c.len()),
                });
            }
        }
        Ok(())
    }

    /// Column `name` as what `pick` makes of it; `want` names what it accepts.
    fn typed<'a, R>(
        &'a self,
        table: &str,
        name: &str,
        want: &str,
        pick: impl Fn(&'a Column) -> Option<R>,
    ) -> Result<R, TableError> {
        let col = self.column(name).ok_or_else(|| TableError {
            table: table.into(),
            problem: format!(
                "no column `{name}` (columns: {})",
                self.columns
                    .iter()
                    .map(|c| c.0.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        })?;
        pick(col).ok_or_else(|| TableError {
            table: table.into(),
            problem: format!("column `{name}` is {}, expected {want}", col.type_name()),
        })
    }

    /// A float column by name.
    pub fn f64s(&self, table: &str, name: &str) -> Result<&[f64], TableError> {
        self.typed(table, name, "float64", |c| match c {
            Column::F64(v) => Some(v.as_slice()),
            _ => None,
        })
    }

    /// An integer column by name, as 64-bit integers: borrowed when it holds them, widened
    /// when it holds 32-bit ones (as other tools often write counts and ids).
    pub fn i64s(&self, table: &str, name: &str) -> Result<std::borrow::Cow<'_, [i64]>, TableError> {
        let integers = self.typed(table, name, "an integer column (int64 or int32)", |c| {
            c.integers()
        })?;
        Ok(integers.to_i64())
    }

    /// An index column by name: 32-bit or 64-bit integers.
    pub fn indices(&self, table: &str, name: &str) -> Result<Indices<'_>, TableError> {
        self.typed(table, name, "int32 or int64", Column::integers)
    }

    /// A text column by name.
    pub fn strs(&self, table: &str, name: &str) -> Result<&[String], TableError> {
        self.typed(table, name, "string", |c| match c {
            Column::Str(v) => Some(v.as_slice()),
            _ => None,
        })
    }
}

/// An integer column read as indices, whichever width it was written in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Indices<'a> {
    /// 32-bit indices (as femu writes matrix tables).
    I32(&'a [i32]),
    /// 64-bit indices (tables written by other tools, or by femu before schema version 3).
    I64(&'a [i64]),
}

impl<'a> Indices<'a> {
    /// Number of indices.
    pub fn len(&self) -> usize {
        match self {
            Indices::I32(v) => v.len(),
            Indices::I64(v) => v.len(),
        }
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Index `k` (which must be below [`Indices::len`]).
    pub fn get(&self, k: usize) -> i64 {
        match self {
            Indices::I32(v) => i64::from(v[k]),
            Indices::I64(v) => v[k],
        }
    }

    /// The indices as 64-bit integers: borrowed when they are, converted otherwise.
    pub fn to_i64(&self) -> std::borrow::Cow<'a, [i64]> {
        match self {
            Indices::I32(v) => v.iter().map(|&i| i64::from(i)).collect(),
            Indices::I64(v) => std::borrow::Cow::Borrowed(v),
        }
    }
}

impl Table {
    /// Header and the first `rows` rows as tab-separated text, with a count of the rest.
    pub fn preview(&self, rows: usize) -> String {
        let mut out = String::new();
        let names: Vec<&str> = self.columns.iter().map(|c| c.0.as_str()).collect();
        out.push_str(&names.join("\t"));
        out.push('\n');
        let n = self.rows().min(rows);
        for r in 0..n {
            let row: Vec<String> = self.columns.iter().map(|c| c.1.cell(r)).collect();
            out.push_str(&row.join("\t"));
            out.push('\n');
        }
        if self.rows() > n {
            out.push_str(&format!("… {} more rows\n", self.rows() - n));
        }
        out
    }
}

impl fmt::Display for Table {
    /// A preview: header and the first 8 rows.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.preview(8))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Index columns read at either width give the same indices; another type is an error
    /// naming the table, the column and what would be valid.
    #[test]
    fn indices_read_at_either_width() {
        let t = Table::new()
            .with("narrow", Column::I32(vec![3, -1, i32::MAX]))
            .with("wide", Column::I64(vec![3, -1, i64::from(i32::MAX)]))
            .with("x", Column::F64(vec![0.0; 3]));
        let (narrow, wide) = (
            t.indices("t", "narrow").unwrap(),
            t.indices("t", "wide").unwrap(),
        );
        assert!(matches!(narrow, Indices::I32(_)) && matches!(wide, Indices::I64(_)));
        assert_eq!(narrow.len(), 3);
        assert_eq!(
            (0..3).map(|k| narrow.get(k)).collect::<Vec<_>>(),
            *wide.to_i64()
        );
        assert_eq!(narrow.to_i64(), wide.to_i64());
        assert!(matches!(wide.to_i64(), std::borrow::Cow::Borrowed(_)));
        let e = t.indices("t", "x").unwrap_err().to_string();
        assert!(
            e.contains("table `t`") && e.contains("`x` is float64, expected int32 or int64"),
            "{e}"
        );
        // Integer columns of either width read as 64-bit integers (other tools write counts
        // and ids as int32): borrowed when they are 64-bit, widened otherwise.
        assert_eq!(
            *t.i64s("t", "narrow").unwrap(),
            [3, -1, i64::from(i32::MAX)]
        );
        assert!(matches!(
            t.i64s("t", "wide").unwrap(),
            std::borrow::Cow::Borrowed(_)
        ));
        let e = t.i64s("t", "x").unwrap_err().to_string();
        assert!(
            e.contains("`x` is float64, expected an integer column (int64 or int32)"),
            "{e}"
        );
        assert_eq!(Column::I32(vec![1, 2]).type_name(), "int32");
        assert_eq!(Column::I32(vec![1, -2]).cell(1), "-2");
    }
}
