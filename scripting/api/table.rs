//! Tables of records (MatDEM's `d.status` history): named columns of numbers, one row per
//! `record`, saved as CSV.

use super::field::{number, Field};
use super::{err, write_atomic, Host, RhaiResult};
use rhai::{Dynamic, Engine, Map, INT};
use std::cell::RefCell;
use std::rc::Rc;

#[derive(Debug, Default)]
pub struct TableData {
    pub columns: Vec<(String, Vec<f64>)>,
    pub rows: usize,
}

/// A shared table handle: every copy in the script refers to the same rows.
#[derive(Debug, Clone, Default)]
pub struct Table(pub Rc<RefCell<TableData>>);

impl TableData {
    /// Appends a row; a new column is back-filled with NaN, a missing value is NaN.
    pub fn push(&mut self, row: &[(String, f64)]) {
        for (name, _) in row {
            if !self.columns.iter().any(|(c, _)| c == name) {
                self.columns.push((name.clone(), vec![f64::NAN; self.rows]));
            }
        }
        for (name, col) in &mut self.columns {
            col.push(row.iter().find(|(n, _)| n == name).map_or(f64::NAN, |(_, v)| *v));
        }
        self.rows += 1;
    }

    pub fn column(&self, name: &str) -> RhaiResult<&[f64]> {
        self.columns.iter().find(|(c, _)| c == name).map(|(_, v)| v.as_slice()).ok_or_else(|| {
            let known: Vec<&str> = self.columns.iter().map(|(c, _)| c.as_str()).collect();
            let hint = matdem_engine::error::did_you_mean(name, &known);
            err(format!("no column `{name}`{hint}; columns: {}", known.join(", ")))
        })
    }

    /// A table from CSV text (RFC 4180: a quoted cell may hold commas, quotes and line
    /// breaks): a header of column names, then rows of numbers (empty or `NaN` cells are NaN).
    /// Blank lines are skipped; cells and names are trimmed of surrounding spaces.
    pub fn from_csv(text: &str) -> Result<Self, String> {
        let mut reader = csv::ReaderBuilder::new().has_headers(false).flexible(true).from_reader(text.as_bytes());
        let mut records = reader.records().filter(|r| {
            // A line of spaces reads as one blank cell: skip it as a blank line.
            !matches!(r, Ok(rec) if rec.len() == 1 && rec[0].trim().is_empty())
        });
        let line = |r: &csv::StringRecord| r.position().map_or(0, |p| p.line());
        let header = match records.next() {
            None => return Err("the file is empty; expected a header line of column names".into()),
            Some(r) => r.map_err(|e| format!("cannot read the header: {e}"))?,
        };
        let names: Vec<String> = header.iter().map(|c| c.trim().to_string()).collect();
        // Columns are found by name: a second one of a name would be dropped without a word.
        for (k, name) in names.iter().enumerate() {
            if let Some(first) = names[..k].iter().position(|n| n == name) {
                return Err(format!(
                    "column `{name}` is given twice (columns {} and {}); rename one in the header",
                    first + 1,
                    k + 1
                ));
            }
        }
        let mut table = TableData::default();
        for record in records {
            let record = record.map_err(|e| format!("cannot read the file as CSV: {e}"))?;
            let k = line(&record);
            if record.len() != names.len() {
                return Err(format!("line {k} has {} cells; the header has {}", record.len(), names.len()));
            }
            let row = names
                .iter()
                .zip(record.iter().map(str::trim))
                .map(|(name, cell)| match cell {
                    "" => Ok((name.clone(), f64::NAN)),
                    _ => match cell.parse::<f64>() {
                        // A number too large for f64 reads as inf: say so rather than keep it.
                        Ok(x) if x.is_infinite() && !is_infinity_word(cell) => Err(format!(
                            "line {k}, column `{name}`: `{cell}` is beyond the range of a 64-bit float \
                             (±1.8e308); give it in other units"
                        )),
                        Ok(x) => Ok((name.clone(), x)),
                        Err(_) => Err(format!("line {k}, column `{name}`: `{cell}` is not a number")),
                    },
                })
                .collect::<Result<Vec<_>, _>>()?;
            table.push(&row);
        }
        if table.rows == 0 {
            table.columns = names.into_iter().map(|n| (n, Vec::new())).collect();
        }
        Ok(table)
    }

    /// The table as CSV: a header of column names, then one row per record. Names are
    /// quoted per RFC 4180 where they need it (a comma, a quote, a line break); numbers are
    /// written as Rust's `{}` writes them, NaN (a missing value) as `NaN`.
    pub fn to_csv(&self) -> String {
        if self.columns.is_empty() {
            // NOTE: a CSV writer spells an empty record `""`; a table without columns has
            // always been written as empty lines.
            return "\n".repeat(self.rows + 1);
        }
        let mut w = csv::Writer::from_writer(Vec::new());
        let rows = std::iter::once(self.columns.iter().map(|(c, _)| c.clone()).collect::<Vec<_>>())
            .chain((0..self.rows).map(|r| self.columns.iter().map(|(_, v)| format!("{}", v[r])).collect()));
        for row in rows {
            w.write_record(&row).expect("a CSV record of equal length written to memory cannot fail");
        }
        let bytes = w.into_inner().expect("flushing a CSV writer into memory cannot fail");
        String::from_utf8(bytes).expect("CSV of UTF-8 names and numbers is UTF-8")
    }
}

/// `inf` or `infinity` (any case, any sign): an infinity written as one, not an overflow.
fn is_infinity_word(cell: &str) -> bool {
    let word = cell.trim_start_matches(['+', '-']).to_ascii_lowercase();
    word == "inf" || word == "infinity"
}

/// A row from a script map of numbers.
pub fn row_from_map(map: &Map) -> RhaiResult<Vec<(String, f64)>> {
    map.iter()
        .map(|(k, v)| {
            number(v)
                .map(|x| (k.to_string(), x))
                .ok_or_else(|| err(format!("record value `{k}` is a {}, expected a number", v.type_name())))
        })
        .collect()
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    engine.register_type_with_name::<Table>("Table");
    engine
        .register_fn("new_table", Table::default)
        .register_fn("add_row", |t: &mut Table, row: Map| -> RhaiResult<()> {
            t.0.borrow_mut().push(&row_from_map(&row)?);
            Ok(())
        })
        .register_get("rows", |t: &mut Table| t.0.borrow().rows as INT)
        .register_fn("len", |t: &mut Table| t.0.borrow().rows as INT)
        .register_get("columns", |t: &mut Table| {
            t.0.borrow().columns.iter().map(|(c, _)| Dynamic::from(c.clone())).collect::<rhai::Array>()
        })
        .register_indexer_get(|t: &mut Table, name: &str| -> RhaiResult<Field> {
            Ok(Field::new(t.0.borrow().column(name)?.to_vec()))
        })
        .register_fn("last", |t: &mut Table, name: &str| -> RhaiResult<f64> {
            t.0.borrow().column(name)?.last().copied().ok_or_else(|| err("the table has no rows yet"))
        })
        .register_fn("to_string", |t: &mut Table| {
            let d = t.0.borrow();
            format!(
                "Table({} rows; {})",
                d.rows,
                d.columns.iter().map(|(c, _)| c.as_str()).collect::<Vec<_>>().join(", ")
            )
        });
    // Journaled: a resumed run does not rewrite the tables finished before its interruption.
    engine.register_fn("save", move |t: &mut Table, name: &str| -> RhaiResult<Dynamic> {
        host.observe("save_table", || {
            let path = host.out_path(name)?;
            write_atomic(&path, t.0.borrow().to_csv().as_bytes())
                .map_err(|e| err(format!("cannot write {}: {e}", path.display())))?;
            host.note_written([path.clone()]);
            Ok(Dynamic::from(path.display().to_string()))
        })
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(rows: &[&[(&str, f64)]]) -> TableData {
        let mut t = TableData::default();
        for row in rows {
            t.push(&row.iter().map(|(n, v)| (n.to_string(), *v)).collect::<Vec<_>>());
        }
        t
    }

    #[test]
    fn csv_without_names_that_need_quotes_is_written_as_before() {
        let t = table(&[&[("step", 0.0), ("stress", 2.5e-7)], &[("step", 100.0), ("stress", 1e21), ("extra", 0.1)]]);
        assert_eq!(t.to_csv(), "step,stress,extra\n0,0.00000025,NaN\n100,1000000000000000000000,0.1\n");
        assert_eq!(TableData::default().to_csv(), "\n");
    }

    #[test]
    fn a_column_name_with_a_comma_a_quote_and_a_line_break_is_quoted_and_reads_back() {
        let t = table(&[&[("a,b\nc", 1.0), ("say \"hi\"", 2.0)]]);
        let text = t.to_csv();
        assert_eq!(text, "\"a,b\nc\",\"say \"\"hi\"\"\"\n1,2\n");
        let back = TableData::from_csv(&text).unwrap();
        assert_eq!(back.columns.iter().map(|(c, _)| c.as_str()).collect::<Vec<_>>(), ["a,b\nc", "say \"hi\""]);
        assert_eq!(back.column("a,b\nc").unwrap(), [1.0]);
    }

    #[test]
    fn hand_written_csv_with_spaces_blank_lines_and_empty_cells_still_reads() {
        let t = TableData::from_csv("x, y\n\n1, 2\n   \n3,\n").unwrap();
        assert_eq!(t.rows, 2);
        assert_eq!(t.column("y").unwrap()[0], 2.0);
        assert!(t.column("y").unwrap()[1].is_nan());
        let e = TableData::from_csv("x,y\n1,2,3\n").unwrap_err();
        assert!(e.contains("line 2 has 3 cells; the header has 2"), "{e}");
        let e = TableData::from_csv("x,y,x\n1,2,3\n").unwrap_err();
        assert!(e.contains("column `x` is given twice (columns 1 and 3)"), "{e}");
        let e = TableData::from_csv("x\n-1e400\n").unwrap_err();
        assert!(e.contains("line 2, column `x`: `-1e400` is beyond the range"), "{e}");
        assert_eq!(TableData::from_csv("x\n-inf\n").unwrap().column("x").unwrap(), [f64::NEG_INFINITY]);
        let e = TableData::from_csv("x\nabc\n").unwrap_err();
        assert!(e.contains("line 2, column `x`: `abc` is not a number"), "{e}");
        assert!(TableData::from_csv("").unwrap_err().contains("empty"));
    }
}
