//! CSV files with a header (native dataset tables, robot logs), read whole with the 1-based line
//! of every row so errors can name it.

use crate::error::{DataError, Result};
use crate::io::read_text;
use std::path::{Path, PathBuf};

/// A CSV file with a header, read whole: lower-cased header names and the rows with the 1-based
/// line each starts on.
pub(crate) struct CsvTable {
    path: PathBuf,
    header: Vec<String>,
    /// The rows and their lines.
    pub(crate) rows: Vec<(usize, csv::StringRecord)>,
}

impl CsvTable {
    /// Reads `path`: text (binary garbage is an error), a header line, rows of the header's width.
    pub(crate) fn read(path: &Path) -> Result<Self> {
        let text = read_text(path)?;
        if text.trim().is_empty() {
            return Err(DataError::parse(
                path,
                1,
                "empty file; expected a header line",
            ));
        }
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let header: Vec<String> = reader
            .headers()
            .map_err(|e| csv_error(path, &e))?
            .iter()
            .map(str::to_ascii_lowercase)
            .collect();
        for (i, h) in header.iter().enumerate() {
            if header[..i].contains(h) {
                return Err(DataError::parse(
                    path,
                    1,
                    format!("column '{h}' appears twice"),
                ));
            }
        }
        let mut rows = Vec::new();
        for record in reader.records() {
            let record = record.map_err(|e| csv_error(path, &e))?;
            let line = record.position().map_or(0, |p| p.line() as usize);
            rows.push((line, record));
        }
        Ok(Self {
            path: path.to_path_buf(),
            header,
            rows,
        })
    }

    /// Index of a column that must be present.
    pub(crate) fn column(&self, name: &str) -> Result<usize> {
        self.optional_column(name).ok_or_else(|| {
            DataError::parse(
                &self.path,
                1,
                format!(
                    "missing column '{name}' (header: {})",
                    self.header.join(",")
                ),
            )
        })
    }

    /// Indices of columns that must all be present; the error lists every missing one.
    pub(crate) fn columns(&self, names: &[&str]) -> Result<Vec<usize>> {
        let missing: Vec<&str> = names
            .iter()
            .copied()
            .filter(|n| self.optional_column(n).is_none())
            .collect();
        if !missing.is_empty() {
            return Err(DataError::parse(
                &self.path,
                1,
                format!(
                    "missing column(s) {} (header: {}; expected {})",
                    missing.join(","),
                    self.header.join(","),
                    names.join(",")
                ),
            ));
        }
        names.iter().map(|n| self.column(n)).collect()
    }

    /// Index of a column that may be absent.
    pub(crate) fn optional_column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }
}

/// A cell of a row read by [`CsvTable`] (rows have the header's width, so it is always there).
pub(crate) fn cell(row: &csv::StringRecord, col: usize) -> &str {
    row.get(col).unwrap_or("")
}

fn csv_error(path: &Path, e: &csv::Error) -> DataError {
    let line = e.position().map_or(1, |p| p.line() as usize);
    match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => DataError::parse(
            path,
            line,
            format!("{len} fields, but the header has {expected_len}"),
        ),
        _ => DataError::parse(path, line, e.to_string()),
    }
}

/// CSV bytes of a header and rows (fields are quoted where CSV needs it).
pub(crate) fn csv_bytes(path: &Path, header: &[&str], rows: Vec<Vec<String>>) -> Result<Vec<u8>> {
    let to_err = |e: csv::Error| DataError::invalid(path, e.to_string());
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record(header).map_err(to_err)?;
    for row in rows {
        w.write_record(&row).map_err(to_err)?;
    }
    w.into_inner()
        .map_err(|e| DataError::invalid(path, e.to_string()))
}
