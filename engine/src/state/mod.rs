//! The model's state: particles (struct of arrays), contact rows with per-pair state, groups.

pub mod body_work;
pub mod contacts;
pub mod groups;
pub mod particles;

/// Checks CSR row starts as a loaded checkpoint must have them before anything indexes with
/// them: `rows + 1` starts, the first 0, none before the one above it, the last `items`.
/// The error names `what` and the first start that is wrong.
pub(crate) fn check_row_starts(what: &str, start: &[u32], rows: usize, items: usize) -> Result<(), String> {
    if start.len() != rows + 1 {
        return Err(format!("{what}: {} row starts for {rows} rows (need {})", start.len(), rows + 1));
    }
    if start[0] != 0 {
        return Err(format!("{what}: the first row starts at entry {}, not 0", start[0]));
    }
    if let Some(i) = start.windows(2).position(|w| w[0] > w[1]) {
        return Err(format!(
            "{what}: row {} starts at entry {}, before row {i}'s start {}",
            i + 1,
            start[i + 1],
            start[i]
        ));
    }
    if start[rows] as usize != items {
        return Err(format!("{what}: the rows end at entry {} but there are {items} entries", start[rows]));
    }
    Ok(())
}
