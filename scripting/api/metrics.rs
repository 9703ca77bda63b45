//! `report(name, value)`: the scalar results a script stands by, written to `metrics.csv`
//! in the run's output folder (its format: [`crate::metrics`]). `matdem-rs study` reads them
//! back to compare settings.

use super::{err, write_atomic, Host, RhaiResult};
use crate::metrics::{check_metric_name, to_csv, METRICS_FILE};
use rhai::{Engine, FLOAT, INT};
use std::cell::RefCell;
use std::rc::Rc;

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    let metrics: Rc<RefCell<Vec<(String, f64)>>> = Rc::default();
    let report = move |name: &str, value: f64| -> RhaiResult<()> {
        check_name(name)?;
        // A study or sweep compares metrics across runs: NaN or inf there is a failed
        // computation, better stopped here than found as a gap in a table later.
        if !value.is_finite() {
            return Err(err(format!(
                "report: `{name}` is {value}; a metric must be a finite number — check what computed it (a mean of \
                 nothing, a division by zero), or leave it unreported"
            )));
        }
        {
            let mut m = metrics.borrow_mut();
            match m.iter_mut().find(|(n, _)| n == name) {
                Some(slot) => slot.1 = value,
                None => m.push((name.to_string(), value)),
            }
        }
        // A resumed run's replay keeps the values but leaves the file as it was written.
        if host.replaying() {
            return Ok(());
        }
        // Rewritten whole at each report, so an interrupted run keeps what it reported.
        // The host's own file, which a script's save may not name.
        let path = crate::sandbox::host_output_path(&host.out_dir, METRICS_FILE).map_err(err)?;
        let text = to_csv(&metrics.borrow());
        write_atomic(&path, text.as_bytes()).map_err(|e| err(format!("cannot write {}: {e}", path.display())))?;
        if !host.written.borrow().contains(&path) {
            host.note_written([path]);
        }
        Ok(())
    };
    let report_int = report.clone();
    engine
        .register_fn("report", move |name: &str, value: FLOAT| report(name, value))
        .register_fn("report", move |name: &str, value: INT| report_int(name, value as f64));
}

/// Names become CSV cells and `--metric` arguments: keep them to one plain word.
fn check_name(name: &str) -> RhaiResult<()> {
    check_metric_name(name).map_err(|e| err(format!("report: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metric_names_with_commas_or_spaces_are_refused() {
        assert!(check_name("strain_no1").is_ok());
        for bad in ["", "a,b", "a b", "x\n"] {
            assert!(check_name(bad).is_err(), "{bad:?}");
        }
    }
}
