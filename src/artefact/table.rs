//! Column tables: the in-memory form every artefact is made of, whatever the file format.

use std::fmt;

/// One typed column.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// 64-bit floats.
    F64(Vec<f64>),
    /// 64-bit integers.
    I64(Vec<i64>),
    /// UTF-8 text.
    Str(Vec<String>),
}

impl Column {
    /// Number of rows.
    pub fn len(&self) -> usize {
        match self {
            Column::F64(v) => v.len(),
            Column::I64(v) => v.len(),
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
            Column::Str(_) => "string",
        }
    }

    /// The value at `row` as text (for previews).
    pub fn cell(&self, row: usize) -> String {
        match self {
            Column::F64(v) => format!("{:.6e}", v[row]),
            Column::I64(v) => v[row].to_string(),
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

    fn typed<'a, T>(
        &'a self,
        table: &str,
        name: &str,
        want: &str,
        pick: impl Fn(&'a Column) -> Option<&'a Vec<T>>,
    ) -> Result<&'a [T], TableError> {
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
        pick(col).map(|v| v.as_slice()).ok_or_else(|| TableError {
            table: table.into(),
            problem: format!("column `{name}` is {}, expected {want}", col.type_name()),
        })
    }

    /// A float column by name.
    pub fn f64s(&self, table: &str, name: &str) -> Result<&[f64], TableError> {
        self.typed(table, name, "float64", |c| match c {
            Column::F64(v) => Some(v),
            _ => None,
        })
    }

    /// An integer column by name.
    pub fn i64s(&self, table: &str, name: &str) -> Result<&[i64], TableError> {
        self.typed(table, name, "int64", |c| match c {
            Column::I64(v) => Some(v),
            _ => None,
        })
    }

    /// A text column by name.
    pub fn strs(&self, table: &str, name: &str) -> Result<&[String], TableError> {
        self.typed(table, name, "string", |c| match c {
            Column::Str(v) => Some(v),
            _ => None,
        })
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
