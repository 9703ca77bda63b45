//! `report(name, value)`: the scalar results a script stands by, written to `metrics.csv`
//! in the run's output folder. `matdem-rs study` reads them back to compare settings.

use super::{err, write_atomic, Host, RhaiResult};
use rhai::{Engine, FLOAT, INT};
use std::cell::RefCell;
use std::rc::Rc;

/// The file a run's metrics go to, one `name,value` row each, in the order first reported.
pub const METRICS_FILE: &str = "metrics.csv";

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

/// A metric name: one plain word of letters, digits, `_` or `.`.
pub fn check_metric_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(format!("metric name `{}` must be letters, digits, `_` or `.` (e.g. \"strain_no1\")", name.escape_debug()))
    }
}

fn to_csv(metrics: &[(String, f64)]) -> String {
    let mut w = csv::Writer::from_writer(Vec::new());
    let rows = std::iter::once(["name".to_string(), "value".to_string()])
        // `{:?}` prints the shortest string that reads back to the same f64.
        .chain(metrics.iter().map(|(n, v)| [n.clone(), format!("{v:?}")]));
    for row in rows {
        w.write_record(&row).expect("a CSV record written to memory cannot fail");
    }
    String::from_utf8(w.into_inner().expect("flushing a CSV writer into memory cannot fail"))
        .expect("CSV of UTF-8 names and numbers is UTF-8")
}

/// Reads a `metrics.csv` written by [`register`]'s `report`.
pub fn parse_metrics(text: &str) -> Result<Vec<(String, f64)>, String> {
    let mut reader = csv::ReaderBuilder::new().has_headers(false).flexible(true).from_reader(text.as_bytes());
    let mut records = reader.records();
    match records.next() {
        Some(Ok(h)) if h.len() == 2 && &h[0] == "name" && &h[1] == "value" => {}
        _ => return Err("not a metrics file: the first line is not `name,value`".into()),
    }
    records
        .map(|r| {
            let r = r.map_err(|e| format!("bad metrics file: {e}"))?;
            let line = r.iter().collect::<Vec<_>>().join(",");
            if r.len() != 2 {
                return Err(format!("bad metrics line `{line}`"));
            }
            let v: f64 = r[1].parse().map_err(|_| format!("bad metric value in `{line}`"))?;
            Ok((r[0].to_string(), v))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_round_trip_bitwise_through_csv() {
        let m = vec![("a".to_string(), 0.1 + 0.2), ("b_2".to_string(), -1.5e-300), ("c".to_string(), f64::NAN)];
        let back = parse_metrics(&to_csv(&m)).unwrap();
        assert_eq!(back.len(), 3);
        assert_eq!(back[0], m[0]);
        assert_eq!(back[1].1.to_bits(), m[1].1.to_bits());
        assert!(back[2].1.is_nan());
    }

    #[test]
    fn metric_names_with_commas_or_spaces_are_refused() {
        assert!(check_name("strain_no1").is_ok());
        for bad in ["", "a,b", "a b", "x\n"] {
            assert!(check_name(bad).is_err(), "{bad:?}");
        }
    }
}
