//! `metrics.csv`: the scalar results a script stands by (`report(name, value)`, see
//! `api::metrics`), one `name,value` row each, in the output folder of its run. A study or a
//! sweep reads them back to compare runs; the sandbox keeps the name for the host.

/// The file a run's metrics go to, one `name,value` row each, in the order first reported.
pub const METRICS_FILE: &str = "metrics.csv";

/// A metric name: one plain word of letters, digits, `_` or `.`.
pub fn check_metric_name(name: &str) -> Result<(), String> {
    let ok = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '.');
    if ok {
        Ok(())
    } else {
        Err(format!("metric name `{}` must be letters, digits, `_` or `.` (e.g. \"strain_no1\")", name.escape_debug()))
    }
}

/// The text of `metrics.csv`: a `name,value` header, then one row per metric.
pub fn to_csv(metrics: &[(String, f64)]) -> String {
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

/// Reads a `metrics.csv` written by [`to_csv`] (the script's `report`).
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
}
