//! Tables of records (MatDEM's `d.status` history): named columns of numbers, one row per
//! `record`, saved as CSV. A table the host makes may also carry columns of text (the
//! contact table's wall names and bond states), read as arrays of strings.

use super::arrays::{number, Field};
use super::{err, write_atomic, Host, RhaiResult};
use crate::memory::Charge;
use rhai::{Dynamic, Engine, Map, INT};
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

#[derive(Debug, Default)]
pub struct TableData {
    pub columns: Vec<(String, Vec<f64>)>,
    pub rows: usize,
    /// Each column's position by name: a row of many columns is added in time linear in it
    /// (a 200,000-column CSV took 98 s to load when every cell searched the columns).
    index: HashMap<String, usize>,
    /// The table's numbers in the run's memory budget.
    charge: Charge,
    /// Columns of text, each placed before the numeric column of index `at` (after them all
    /// when `at` is their count); host-made tables only (`add_row` and CSV give numbers).
    pub text: Vec<TextColumn>,
}

/// A column of text in a [`TableData`].
#[derive(Debug, Clone, PartialEq)]
pub struct TextColumn {
    pub name: String,
    pub at: usize,
    pub values: Vec<String>,
}

/// A shared table handle: every copy in the script refers to the same rows.
#[derive(Debug, Clone, Default)]
pub struct Table(pub Rc<RefCell<TableData>>);

/// A [`TableData::from_csv`] that stopped early: the text is not a table, or the run was
/// cancelled (a signal) while it was read.
#[derive(Debug, Clone, PartialEq)]
pub enum CsvError {
    Invalid(String),
    Cancelled,
}

/// Cells read between two looks at the cancel flag.
const CELLS_PER_CANCEL_CHECK: usize = 1 << 16;

impl TableData {
    /// A table of whole columns (each `rows` long), its numbers counted in the memory budget.
    pub fn from_columns(columns: Vec<(String, Vec<f64>)>, rows: usize) -> Self {
        let mut index = HashMap::with_capacity(columns.len());
        for (k, (name, _)) in columns.iter().enumerate() {
            index.entry(name.clone()).or_insert(k);
        }
        let bytes = columns.iter().map(|(_, v)| 8 * v.capacity() as u64).sum();
        TableData { columns, rows, index, charge: Charge::counted(bytes), text: Vec::new() }
    }

    /// Adds a column of text (one value per row) before the numeric column `at`.
    pub fn with_text(mut self, name: &str, at: usize, values: Vec<String>) -> Self {
        debug_assert_eq!(values.len(), self.rows, "a text column of {} values for {} rows", values.len(), self.rows);
        self.charge.add(values.iter().map(|v| v.len() as u64 + 24).sum());
        self.text.push(TextColumn { name: name.to_string(), at: at.min(self.columns.len()), values });
        self
    }

    /// The column names in order, text columns in their places.
    pub fn names(&self) -> Vec<&str> {
        let mut out = Vec::with_capacity(self.columns.len() + self.text.len());
        for k in 0..=self.columns.len() {
            out.extend(self.text.iter().filter(|t| t.at == k).map(|t| t.name.as_str()));
            if let Some((name, _)) = self.columns.get(k) {
                out.push(name.as_str());
            }
        }
        out
    }

    /// Row `r`'s cells as text, in the order of [`names`](Self::names).
    fn cells(&self, r: usize) -> Vec<String> {
        let mut out = Vec::with_capacity(self.columns.len() + self.text.len());
        for k in 0..=self.columns.len() {
            out.extend(self.text.iter().filter(|t| t.at == k).map(|t| t.values[r].clone()));
            if let Some((_, v)) = self.columns.get(k) {
                out.push(format!("{}", v[r]));
            }
        }
        out
    }

    /// Appends a row; a new column is back-filled with NaN, a missing value is NaN. A name
    /// given twice keeps its first value.
    pub fn push(&mut self, row: &[(String, f64)]) {
        for (_, col) in &mut self.columns {
            col.push(f64::NAN);
        }
        // A text column gets an empty cell (rows add numbers only).
        for t in &mut self.text {
            t.values.push(String::new());
        }
        let mut slots = Vec::with_capacity(row.len());
        for (name, _) in row {
            let k = match self.index.get(name) {
                Some(&k) => k,
                None => {
                    self.charge.add(8 * self.rows as u64);
                    self.columns.push((name.clone(), vec![f64::NAN; self.rows + 1]));
                    self.index.insert(name.clone(), self.columns.len() - 1);
                    self.columns.len() - 1
                }
            };
            slots.push(k);
        }
        // In reverse, so that the first of a name given twice is written last.
        for (&k, (_, value)) in slots.iter().zip(row).rev() {
            self.columns[k].1[self.rows] = *value;
        }
        self.rows += 1;
        self.charge.add(8 * self.columns.len() as u64);
    }

    pub fn column(&self, name: &str) -> RhaiResult<&[f64]> {
        if self.text.iter().any(|t| t.name == name) {
            return Err(err(format!("column `{name}` holds text, not numbers; read it with t[\"{name}\"] (an array)")));
        }
        self.index.get(name).map(|&k| self.columns[k].1.as_slice()).ok_or_else(|| {
            let known = self.names();
            let hint = matdem_engine::error::did_you_mean(name, &known);
            err(format!("no column `{name}`{hint}; columns: {}", known.join(", ")))
        })
    }

    /// A table from CSV text (RFC 4180: a quoted cell may hold commas, quotes and line
    /// breaks): a header of column names, then rows of numbers (empty or `NaN` cells are NaN).
    /// Blank lines are skipped; cells and names are trimmed of surrounding spaces.
    pub fn from_csv(text: &str) -> Result<Self, String> {
        Self::from_csv_until(text, &|| false).map_err(|e| match e {
            CsvError::Invalid(why) => why,
            CsvError::Cancelled => "cancelled".to_string(),
        })
    }

    /// [`TableData::from_csv`] that gives up soon after `cancelled()` turns true.
    pub fn from_csv_until(text: &str, cancelled: &dyn Fn() -> bool) -> Result<Self, CsvError> {
        let invalid = CsvError::Invalid;
        let mut reader = csv::ReaderBuilder::new().has_headers(false).flexible(true).from_reader(text.as_bytes());
        let mut records = reader.records().filter(|r| {
            // A line of spaces reads as one blank cell: skip it as a blank line.
            !matches!(r, Ok(rec) if rec.len() == 1 && rec[0].trim().is_empty())
        });
        let line = |r: &csv::StringRecord| r.position().map_or(0, |p| p.line());
        let header = match records.next() {
            None => return Err(invalid("the file is empty; expected a header line of column names".into())),
            Some(r) => r.map_err(|e| invalid(format!("cannot read the header: {e}")))?,
        };
        let names: Vec<String> = header.iter().map(|c| c.trim().to_string()).collect();
        // Columns are found by name: a second one of a name would be dropped without a word.
        // A map of first positions keeps this linear in the columns (200,000 of them).
        let mut first: HashMap<&str, usize> = HashMap::with_capacity(names.len());
        for (k, name) in names.iter().enumerate() {
            if let Some(j) = first.insert(name.as_str(), k) {
                return Err(invalid(format!(
                    "column `{name}` is given twice (columns {} and {}); rename one in the header",
                    j + 1,
                    k + 1
                )));
            }
        }
        let mut values: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
        let (mut rows, mut cells) = (0, 0);
        for record in records {
            let record = record.map_err(|e| invalid(format!("cannot read the file as CSV: {e}")))?;
            let k = line(&record);
            if record.len() != names.len() {
                return Err(invalid(format!("line {k} has {} cells; the header has {}", record.len(), names.len())));
            }
            for (j, cell) in record.iter().map(str::trim).enumerate() {
                let x = match cell {
                    "" => f64::NAN,
                    _ => match cell.parse::<f64>() {
                        // A number too large for f64 reads as inf: say so rather than keep it.
                        Ok(x) if x.is_infinite() && !is_infinity_word(cell) => {
                            return Err(invalid(format!(
                                "line {k}, column `{}`: `{cell}` is beyond the range of a 64-bit float \
                                 (±1.8e308); give it in other units",
                                names[j]
                            )))
                        }
                        Ok(x) => x,
                        Err(_) => {
                            return Err(invalid(format!("line {k}, column `{}`: `{cell}` is not a number", names[j])))
                        }
                    },
                };
                values[j].push(x);
                cells += 1;
                if cells % CELLS_PER_CANCEL_CHECK == 0 && cancelled() {
                    return Err(CsvError::Cancelled);
                }
            }
            rows += 1;
        }
        Ok(TableData::from_columns(names.into_iter().zip(values).collect(), rows))
    }

    /// The table as CSV: a header of column names, then one row per record. Names are
    /// quoted per RFC 4180 where they need it (a comma, a quote, a line break); numbers are
    /// written as Rust's `{}` writes them, NaN (a missing value) as `NaN`.
    pub fn to_csv(&self) -> String {
        if self.columns.is_empty() && self.text.is_empty() {
            // NOTE: a CSV writer spells an empty record `""`; a table without columns has
            // always been written as empty lines.
            return "\n".repeat(self.rows + 1);
        }
        let mut w = csv::Writer::from_writer(Vec::new());
        let header: Vec<String> = self.names().into_iter().map(str::to_string).collect();
        let rows = std::iter::once(header).chain((0..self.rows).map(|r| self.cells(r)));
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
            t.0.borrow().names().into_iter().map(|c| Dynamic::from(c.to_string())).collect::<rhai::Array>()
        })
        .register_indexer_get(|t: &mut Table, name: &str| -> RhaiResult<Dynamic> {
            let d = t.0.borrow();
            if let Some(text) = d.text.iter().find(|c| c.name == name) {
                return Ok(Dynamic::from_array(text.values.iter().map(|v| Dynamic::from(v.clone())).collect()));
            }
            Ok(Dynamic::from(Field::new(d.column(name)?.to_vec())))
        })
        .register_fn("last", |t: &mut Table, name: &str| -> RhaiResult<f64> {
            t.0.borrow().column(name)?.last().copied().ok_or_else(|| err("the table has no rows yet"))
        })
        .register_fn("to_string", |t: &mut Table| {
            let d = t.0.borrow();
            format!("Table({} rows; {})", d.rows, d.names().join(", "))
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
    fn new_columns_keep_the_order_they_came_in_and_a_csv_name_twice_is_refused() {
        let t = table(&[&[("b", 1.0), ("a", 2.0)], &[("c", 3.0), ("a", 4.0)]]);
        assert_eq!(t.to_csv(), "b,a,c\n1,2,NaN\nNaN,4,3\n");
        let e = TableData::from_csv("x,y,x\n1,2,3\n").unwrap_err().to_string();
        assert!(e.contains("column `x` is given twice (columns 1 and 3)"), "{e}");
    }

    #[test]
    fn text_columns_are_written_in_their_places_and_quoted_where_needed() {
        let t = TableData::from_columns(vec![("i".into(), vec![0.0, 1.0]), ("fn".into(), vec![2.5, -1.0])], 2)
            .with_text("wall", 1, vec![String::new(), "top, platen".into()]);
        assert_eq!(t.names(), ["i", "wall", "fn"]);
        assert_eq!(t.to_csv(), "i,wall,fn\n0,,2.5\n1,\"top, platen\",-1\n");
        assert!(t.column("wall").unwrap_err().to_string().contains("holds text"));
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
