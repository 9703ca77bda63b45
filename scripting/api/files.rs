//! Reading a script's own data files: `read_text(path)` and `load_table(path)` (CSV). Paths
//! are relative to the script's folder or package, through the sandbox.

use super::table::{CsvError, Table, TableData};
use super::{err, Host, RhaiResult};
use crate::memory::Charge;
use rhai::Engine;
use std::cell::RefCell;
use std::rc::Rc;

fn read_text(host: &Host, path: &str) -> RhaiResult<String> {
    let bytes = host.read(path)?;
    String::from_utf8(bytes).map_err(|_| err(format!("`{path}` is not UTF-8 text")))
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    let h = host.clone();
    engine.register_fn("read_text", move |path: &str| read_text(&h, path));
    engine.register_fn("load_table", move |path: &str| -> RhaiResult<Table> {
        let text = read_text(&host, path)?;
        // Every comma or line break may end a cell of 8 bytes: refuse a file whose table could
        // pass the memory limit before reading it (the table counts its real size after).
        let cells = text.bytes().filter(|b| matches!(b, b',' | b'\n')).count() as u64 + 1;
        drop(Charge::new(8 * cells, &format!("load_table(\"{path}\")")).map_err(err)?);
        let control = host.control.clone();
        match TableData::from_csv_until(&text, &|| control.is_cancelled()) {
            Ok(data) => Ok(Table(Rc::new(RefCell::new(data)))),
            Err(CsvError::Invalid(e)) => Err(err(format!("`{path}`: {e}"))),
            Err(CsvError::Cancelled) => Err(super::cancelled(&host)),
        }
    });
}
