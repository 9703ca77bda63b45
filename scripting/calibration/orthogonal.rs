//! Orthogonal arrays Lₙ(qᵐ) of strength 2 by the Rao–Hamming construction: the runs are
//! every vector u of GF(q)ᵗ (n = qᵗ), the columns every non-zero c of GF(q)ᵗ whose first
//! non-zero entry is 1 (m = (qᵗ − 1)/(q − 1)), and run u has level u·c in column c. Any
//! two columns are linearly independent, so every pair of levels meets equally often
//! (n/q² times): L4(2³), L8(2⁷), L9(3⁴), L16(2¹⁵), L16(4⁵), L25(5⁶), L27(3¹³), L32(2³¹),
//! L49(7⁸), L64(8⁹), L81(3⁴⁰), … Arrays are generated, never typed in, and
//! [`OrthogonalArray::check`] proves the property on the generated table.

use super::galois::Field;
use super::{CalibrationError, Result};

/// The most runs an array may have (a design is run point by point).
pub const MAX_RUNS: usize = 4096;

#[derive(Debug, Clone, PartialEq)]
pub struct OrthogonalArray {
    /// Levels per column, q.
    pub levels: usize,
    /// `rows[run][column]`: the level index 0 … q−1.
    pub rows: Vec<Vec<u8>>,
}

impl OrthogonalArray {
    /// The Rao–Hamming array with qᵗ runs and all (qᵗ − 1)/(q − 1) columns. Columns are
    /// ordered by how many base columns they combine, so the first t are the base ones
    /// (run u's digits, slowest first) as in Taguchi's tables.
    pub fn rao_hamming(levels: usize, t: u32) -> Result<Self> {
        Self::rao_hamming_until(levels, t, &|| false)
    }

    /// [`OrthogonalArray::rao_hamming`] that gives up soon after `cancelled()` turns true.
    pub fn rao_hamming_until(levels: usize, t: u32, cancelled: &dyn Fn() -> bool) -> Result<Self> {
        let field = Field::new(levels as u32)?;
        let q = levels;
        let runs = q.checked_pow(t).filter(|&n| n <= MAX_RUNS && t >= 1).ok_or_else(|| {
            CalibrationError::new(format!(
                "an orthogonal array of {q}^{t} runs is larger than {MAX_RUNS} runs; use fewer factors or levels"
            ))
        })?;
        let vector = |mut n: usize| -> Vec<u8> {
            let mut v = vec![0u8; t as usize];
            for slot in v.iter_mut().rev() {
                *slot = (n % q) as u8;
                n /= q;
            }
            v
        };
        let mut columns: Vec<Vec<u8>> =
            (1..runs).map(vector).filter(|c| c.iter().find(|&&x| x != 0) == Some(&1)).collect();
        columns.sort_by_key(|c| {
            (c.iter().filter(|&&x| x != 0).count(), c.iter().map(|&x| std::cmp::Reverse(x)).collect::<Vec<_>>())
        });
        let mut rows = Vec::with_capacity(runs);
        for r in 0..runs {
            if cancelled() {
                return Err(cancellation());
            }
            let u = vector(r);
            rows.push(
                columns
                    .iter()
                    .map(|c| u.iter().zip(c).fold(0u8, |acc, (&a, &b)| field.add(acc, field.mul(a, b))))
                    .collect(),
            );
        }
        Ok(OrthogonalArray { levels: q, rows })
    }

    /// The smallest array of `levels` levels with at least `factors` columns, with all its
    /// columns (a design uses the first `factors`; the empty rest give an ANOVA its error
    /// degrees of freedom).
    pub fn for_factors(levels: usize, factors: usize) -> Result<Self> {
        Self::for_factors_until(levels, factors, &|| false)
    }

    /// [`OrthogonalArray::for_factors`] that gives up soon after `cancelled()` turns true.
    pub fn for_factors_until(levels: usize, factors: usize, cancelled: &dyn Fn() -> bool) -> Result<Self> {
        if factors == 0 {
            return Err(CalibrationError::new("an orthogonal design needs at least one factor"));
        }
        let mut t = 2u32;
        loop {
            let a = Self::rao_hamming_until(levels, t, cancelled)?;
            if a.columns() >= factors {
                return Ok(a);
            }
            t += 1;
        }
    }

    /// The array of exactly `runs` runs at `levels` levels (runs must be a power of it,
    /// at least its square), with all its columns.
    pub fn with_runs(runs: usize, levels: usize) -> Result<Self> {
        Self::with_runs_until(runs, levels, &|| false)
    }

    /// [`OrthogonalArray::with_runs`] that gives up soon after `cancelled()` turns true.
    pub fn with_runs_until(runs: usize, levels: usize, cancelled: &dyn Fn() -> bool) -> Result<Self> {
        let mut t = 1u32;
        while levels.checked_pow(t).is_some_and(|n| n < runs) {
            t += 1;
        }
        if t < 2 || levels.checked_pow(t) != Some(runs) {
            return Err(CalibrationError::new(format!(
                "no L{runs} array at {levels} levels: the runs must be a power of the levels, at least their square \
                 (e.g. L9 and L27 at 3 levels, L16 at 2 or 4, L25 at 5, L32 at 2)"
            )));
        }
        Self::rao_hamming_until(levels, t, cancelled)
    }

    pub fn runs(&self) -> usize {
        self.rows.len()
    }

    pub fn columns(&self) -> usize {
        self.rows.first().map_or(0, Vec::len)
    }

    /// Taguchi's name, e.g. `L25(5^6)`.
    pub fn name(&self) -> String {
        format!("L{}({}^{})", self.runs(), self.levels, self.columns())
    }

    /// The first `n` columns.
    pub fn truncated(&self, n: usize) -> Self {
        OrthogonalArray { levels: self.levels, rows: self.rows.iter().map(|r| r[..n.min(r.len())].to_vec()).collect() }
    }

    /// Proves strength 2: every column holds each level n/q times and every pair of
    /// columns holds each pair of levels n/q² times. Names the first offending columns.
    pub fn check(&self) -> Result<()> {
        check_design(&self.rows, self.levels)
    }

    /// [`OrthogonalArray::check`] that gives up soon after `cancelled()` turns true.
    pub fn check_until(&self, cancelled: &dyn Fn() -> bool) -> Result<()> {
        check_design_until(&self.rows, self.levels, cancelled)
    }
}

/// The error of a construction or check given up on a signal.
fn cancellation() -> CalibrationError {
    CalibrationError::new("cancelled by a signal")
}

/// Whether an error is a [`cancellation`].
pub fn is_cancellation(e: &CalibrationError) -> bool {
    *e == cancellation()
}

/// The strength-2 check on any design of level indices (0 … q−1).
pub fn check_design(rows: &[Vec<u8>], q: usize) -> Result<()> {
    check_design_until(rows, q, &|| false)
}

/// [`check_design`] that gives up soon after `cancelled()` turns true.
///
/// Every pair of columns is counted, n·m²/2 cells in all (L4096(2^4095) has 8.4 million
/// pairs of 4096 runs): one bit a run per column and level, so a pair's counts are popcounts
/// of 64 runs at a time. With every column balanced (each level n/q times), the pair counts
/// of levels below q−1 fix the rest (a row or column of the q×q table sums to n/q), so
/// (q−1)² popcounts a pair prove it. L4096 was checked in 90 s cell by cell.
pub fn check_design_until(rows: &[Vec<u8>], q: usize, cancelled: &dyn Fn() -> bool) -> Result<()> {
    let n = rows.len();
    let m = rows.first().map_or(0, Vec::len);
    // One column only needs balance; pairs of columns need every pair of levels.
    let unit = if m >= 2 { q * q } else { q };
    if n == 0 || !n.is_multiple_of(unit) {
        return Err(CalibrationError::new(format!(
            "{n} runs cannot be orthogonal at {q} levels (need a multiple of {unit})"
        )));
    }
    if let Some(r) = rows.iter().position(|r| r.len() != m || r.iter().any(|&l| l as usize >= q)) {
        return Err(CalibrationError::new(format!("run {} has a wrong length or a level outside 1 … {q}", r + 1)));
    }
    for a in 0..m {
        let mut count = vec![0usize; q];
        rows.iter().for_each(|r| count[r[a] as usize] += 1);
        if let Some(l) = count.iter().position(|&c| c != n / q) {
            return Err(CalibrationError::new(format!(
                "column {} is not balanced: level {} appears {} times, expected {}",
                a + 1,
                l + 1,
                count[l],
                n / q
            )));
        }
    }
    // bits[(a * (q - 1) + l) * words + w]: run 64·w + i has level l in column a.
    let words = n.div_ceil(64);
    let low = q - 1;
    let mut bits = vec![0u64; m * low * words];
    for (r, row) in rows.iter().enumerate() {
        for (a, &l) in row.iter().enumerate() {
            if (l as usize) < low {
                bits[(a * low + l as usize) * words + r / 64] |= 1 << (r % 64);
            }
        }
    }
    let set = |a: usize, l: usize| &bits[(a * low + l) * words..(a * low + l + 1) * words];
    let expected = (n / (q * q)) as u32;
    for a in 0..m {
        if cancelled() {
            return Err(cancellation());
        }
        for b in a + 1..m {
            let orthogonal = (0..low).all(|l| {
                (0..low).all(|k| {
                    set(a, l).iter().zip(set(b, k)).map(|(x, y)| (x & y).count_ones()).sum::<u32>() == expected
                })
            });
            if !orthogonal {
                return Err(pair_error(rows, q, a, b));
            }
        }
    }
    Ok(())
}

/// The message for columns `a` and `b` that are not orthogonal: their first pair of levels
/// that does not meet n/q² times.
fn pair_error(rows: &[Vec<u8>], q: usize, a: usize, b: usize) -> CalibrationError {
    let n = rows.len();
    let mut pairs = vec![0usize; q * q];
    rows.iter().for_each(|r| pairs[r[a] as usize * q + r[b] as usize] += 1);
    let k = pairs.iter().position(|&c| c != n / (q * q)).unwrap_or(0);
    CalibrationError::new(format!(
        "columns {} and {} are not orthogonal: levels ({}, {}) appear together {} times, expected {}",
        a + 1,
        b + 1,
        k / q + 1,
        k % q + 1,
        pairs[k],
        n / (q * q)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_standard_arrays_are_generated_with_their_taguchi_shapes_and_are_orthogonal() {
        for (runs, levels, columns) in [
            (4, 2, 3),
            (8, 2, 7),
            (9, 3, 4),
            (16, 2, 15),
            (16, 4, 5),
            (25, 5, 6),
            (27, 3, 13),
            (32, 2, 31),
            (49, 7, 8),
            (64, 8, 9),
            (81, 9, 10),
        ] {
            let a = OrthogonalArray::with_runs(runs, levels).unwrap();
            assert_eq!((a.runs(), a.columns()), (runs, columns), "{}", a.name());
            a.check().unwrap_or_else(|e| panic!("{}: {e}", a.name()));
        }
        assert_eq!(OrthogonalArray::with_runs(25, 5).unwrap().name(), "L25(5^6)");
    }

    #[test]
    fn the_smallest_array_holding_the_factors_is_chosen() {
        assert_eq!(OrthogonalArray::for_factors(5, 6).unwrap().name(), "L25(5^6)");
        assert_eq!(OrthogonalArray::for_factors(5, 7).unwrap().name(), "L125(5^31)");
        assert_eq!(OrthogonalArray::for_factors(3, 5).unwrap().name(), "L27(3^13)");
        assert_eq!(OrthogonalArray::for_factors(2, 7).unwrap().name(), "L8(2^7)");
    }

    #[test]
    fn a_broken_design_is_caught_naming_the_columns() {
        let mut a = OrthogonalArray::with_runs(25, 5).unwrap();
        a.rows[3][4] = (a.rows[3][4] + 1) % 5;
        let e = a.check().unwrap_err().to_string();
        assert!(e.contains("column 5") || e.contains("and 5"), "{e}");
        // Two equal columns are balanced but not orthogonal.
        let dup: Vec<Vec<u8>> =
            OrthogonalArray::with_runs(9, 3).unwrap().rows.iter().map(|r| vec![r[0], r[0]]).collect();
        assert!(check_design(&dup, 3).unwrap_err().to_string().contains("columns 1 and 2 are not orthogonal"));
    }

    /// The check as it was written first: every cell of every pair's table.
    fn naive(rows: &[Vec<u8>], q: usize) -> bool {
        let (n, m) = (rows.len(), rows[0].len());
        (0..m).all(|a| {
            (0..q).all(|l| rows.iter().filter(|r| r[a] as usize == l).count() == n / q)
                && (a + 1..m).all(|b| {
                    let mut pairs = vec![0usize; q * q];
                    rows.iter().for_each(|r| pairs[r[a] as usize * q + r[b] as usize] += 1);
                    pairs.iter().all(|&c| c == n / (q * q))
                })
        })
    }

    #[test]
    fn the_popcount_check_agrees_with_counting_every_cell() {
        // Arrays with two runs' levels swapped or changed in a column: the fast check (which
        // counts (q−1)² cells a pair) says what counting all q² cells says.
        let mut seed = 12345u64;
        let mut next = |k: usize| {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as usize % k
        };
        let (mut caught, mut kept) = (0, 0);
        for (runs, q) in [(9, 3), (16, 4), (25, 5), (27, 3), (16, 2)] {
            let oa = OrthogonalArray::with_runs(runs, q).unwrap();
            for _ in 0..200 {
                let mut rows = oa.rows.clone();
                let (i, j, c) = (next(runs), next(runs), next(rows[0].len()));
                if next(2) == 0 {
                    let t = rows[i][c];
                    rows[i][c] = rows[j][c];
                    rows[j][c] = t;
                } else {
                    rows[i][c] = next(q) as u8;
                }
                let fast = check_design(&rows, q).is_ok();
                assert_eq!(fast, naive(&rows, q), "L{runs} at {q} levels, runs {i} and {j}, column {c}");
                if fast {
                    kept += 1;
                } else {
                    caught += 1;
                }
            }
        }
        assert!(caught > 100 && kept > 10, "{caught} caught, {kept} still orthogonal");
    }

    #[test]
    fn the_largest_arrays_are_checked_in_seconds_and_a_check_can_be_cancelled() {
        let start = std::time::Instant::now();
        let a = OrthogonalArray::with_runs(2048, 2).unwrap();
        a.check().unwrap();
        // Cell by cell this took 7 s (L2048); a release build now takes well under one.
        assert!(start.elapsed().as_secs_f64() < 20.0, "{:?}", start.elapsed());
        assert!(is_cancellation(&a.check_until(&|| true).unwrap_err()));
        assert!(is_cancellation(&OrthogonalArray::with_runs_until(2048, 2, &|| true).unwrap_err()));
    }

    #[test]
    fn arrays_that_cannot_exist_are_refused_with_the_ones_that_can() {
        let e = OrthogonalArray::with_runs(18, 3).unwrap_err().to_string();
        assert!(e.contains("L9 and L27"), "{e}");
        assert!(OrthogonalArray::for_factors(6, 3).unwrap_err().to_string().contains("prime power"));
    }
}
