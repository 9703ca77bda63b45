//! Reading a script's own data files: `read_text(path)` and `load_table(path)` (CSV). Paths
//! are relative to the script's folder or package, through the sandbox.

use super::table::{Table, TableData};
use super::{err, Host, RhaiResult};
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
        let data = TableData::from_csv(&text).map_err(|e| err(format!("`{path}`: {e}")))?;
        Ok(Table(Rc::new(RefCell::new(data))))
    });
}
