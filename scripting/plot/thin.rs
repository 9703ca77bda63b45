//! Thinning a long series for drawing: a chart 800 pixels wide shows no more of 5 million
//! points than of a few thousand, but drew every one (a 500 MB SVG in 12 s). Only what is
//! drawn is thinned; the series keeps its values.
//!
//! Consecutive points that fall in one pixel column are drawn as a vertical stroke from
//! their lowest to their highest: keeping the first, the lowest, the highest and the last
//! of each such stretch (in their order) draws the same pixels, so a one-point peak
//! survives. A series whose x runs forwards keeps at most four points a column.

/// The points of `run` worth drawing across `columns` equal columns of `[x0, x1]`.
pub fn thin(run: &[(f64, f64)], (x0, x1): (f64, f64), columns: usize) -> Vec<(f64, f64)> {
    let ascending = matches!(x1.partial_cmp(&x0), Some(std::cmp::Ordering::Greater));
    if run.len() <= 4 * columns || columns == 0 || !ascending {
        return run.to_vec();
    }
    let scale = columns as f64 / (x1 - x0);
    let column = |x: f64| ((x - x0) * scale).floor() as i64;
    let mut out = Vec::new();
    let mut start = 0;
    while start < run.len() {
        let c = column(run[start].0);
        let mut end = start + 1;
        while end < run.len() && column(run[end].0) == c {
            end += 1;
        }
        keep_extremes(&run[start..end], &mut out);
        start = end;
    }
    out
}

/// The first, lowest, highest and last points of `stretch`, in their order, each once.
fn keep_extremes(stretch: &[(f64, f64)], out: &mut Vec<(f64, f64)>) {
    let by_y = |a: &(usize, &(f64, f64)), b: &(usize, &(f64, f64))| a.1 .1.total_cmp(&b.1 .1);
    let low = stretch.iter().enumerate().min_by(by_y).map_or(0, |(i, _)| i);
    let high = stretch.iter().enumerate().max_by(by_y).map_or(0, |(i, _)| i);
    let mut keep = [0, low, high, stretch.len() - 1];
    keep.sort_unstable();
    let mut last = None;
    for i in keep {
        if last != Some(i) {
            out.push(stretch[i]);
            last = Some(i);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn five_million_points_keep_a_few_per_column_and_their_one_point_peak() {
        let n = 5_000_000;
        let mut run: Vec<(f64, f64)> = (0..n).map(|i| (i as f64, (i as f64 * 1e-3).sin())).collect();
        run[3_141_593].1 = 50.0;
        run[2_718_281].1 = -50.0;
        let thinned = thin(&run, (0.0, n as f64), 800);
        assert!(thinned.len() <= 4 * 800, "{} points", thinned.len());
        assert!(thinned.contains(&run[3_141_593]) && thinned.contains(&run[2_718_281]), "a peak was lost");
        assert_eq!((thinned[0], thinned[thinned.len() - 1]), (run[0], run[n - 1]));
        assert!(thinned.windows(2).all(|w| w[0].0 <= w[1].0), "order kept");
    }

    #[test]
    fn a_short_series_or_one_that_goes_back_and_forth_is_drawn_as_it_is() {
        let short: Vec<(f64, f64)> = (0..100).map(|i| (i as f64, 1.0)).collect();
        assert_eq!(thin(&short, (0.0, 100.0), 800), short);
        // A loop over the whole range each step: no two consecutive points share a column.
        let zigzag: Vec<(f64, f64)> = (0..10_000).map(|i| (if i % 2 == 0 { 0.0 } else { 99.0 }, i as f64)).collect();
        assert_eq!(thin(&zigzag, (0.0, 100.0), 800).len(), zigzag.len());
    }
}
