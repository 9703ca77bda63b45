//! Single-factor regressions of paper 002 §2.2: a response against one micro parameter as
//! linear y = a·x + b, exponential y = a·e^(b·x), logarithmic y = a·ln x + b or power
//! y = a·x^b. The logarithmic and linear forms are linear least squares; the exponential
//! and power forms start from the fit of ln y (what a spreadsheet trend line reports) and
//! are then refined by Levenberg–Marquardt on y itself, so every form minimises the same
//! squared error and their R² = 1 − SS_res/SS_tot (on y) can be compared to pick the best.

use super::levenberg_marquardt::{minimise, Options};
use super::{CalibrationError, Result};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    Linear,
    Exponential,
    Logarithmic,
    Power,
}

impl Form {
    pub const ALL: [Form; 4] = [Form::Linear, Form::Exponential, Form::Logarithmic, Form::Power];

    pub fn name(self) -> &'static str {
        match self {
            Form::Linear => "linear",
            Form::Exponential => "exponential",
            Form::Logarithmic => "logarithmic",
            Form::Power => "power",
        }
    }

    pub fn parse(s: &str) -> Result<Form> {
        Form::ALL.into_iter().find(|f| f.name() == s).ok_or_else(|| {
            CalibrationError::new(format!(
                "unknown regression form `{s}`; expected one of: linear, exponential, logarithmic, power"
            ))
        })
    }

    pub fn eval(self, a: f64, b: f64, x: f64) -> f64 {
        match self {
            Form::Linear => a * x + b,
            Form::Exponential => a * (b * x).exp(),
            Form::Logarithmic => a * x.ln() + b,
            Form::Power => a * x.powf(b),
        }
    }

    /// x for a given y (the single-factor inversion of paper 002 Table 5); NaN where none.
    pub fn invert(self, a: f64, b: f64, y: f64) -> f64 {
        match self {
            Form::Linear => (y - b) / a,
            Form::Exponential => (y / a).ln() / b,
            Form::Logarithmic => ((y - b) / a).exp(),
            Form::Power => (y / a).powf(1.0 / b),
        }
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    pub form: Form,
    pub a: f64,
    pub b: f64,
    pub r2: f64,
}

impl Fit {
    pub fn predict(&self, x: f64) -> f64 {
        self.form.eval(self.a, self.b, x)
    }

    /// The x at which the fit gives `y` (the single-factor inversion of paper 002 Table 5);
    /// an error that says why where no finite x does (a flat fit, a y the form never reaches).
    pub fn invert(&self, y: f64) -> Result<f64> {
        if !y.is_finite() {
            return Err(CalibrationError::new(format!("the target y = {y} is not a finite number")));
        }
        let flat = self.a == 0.0 || (matches!(self.form, Form::Exponential | Form::Power) && self.b == 0.0);
        if flat {
            return Err(CalibrationError::new(format!(
                "the fit {} is flat: it gives the same y for every x, so no x gives y = {y}; the response does not \
                 change with this factor — invert with a response that does",
                self.formula()
            )));
        }
        let x = self.form.invert(self.a, self.b, y);
        if x.is_finite() {
            return Ok(x);
        }
        let why = match self.form {
            Form::Exponential | Form::Power if y / self.a <= 0.0 => {
                format!("the {} fit only reaches values of the sign of a = {}, never 0", self.form.name(), fmt(self.a))
            }
            _ => "x would be beyond the range of a 64-bit float".to_string(),
        };
        Err(CalibrationError::new(format!("no x gives y = {y} on {}: {why}", self.formula())))
    }

    /// The formula with its numbers, e.g. `y = 2.5·e^(0.3·x)`.
    pub fn formula(&self) -> String {
        let (a, b) = (fmt(self.a), fmt(self.b));
        let sb = |b: f64| if b < 0.0 { format!("− {}", fmt(-b)) } else { format!("+ {}", fmt(b)) };
        match self.form {
            Form::Linear => format!("y = {a}·x {}", sb(self.b)),
            Form::Exponential => format!("y = {a}·e^({b}·x)"),
            Form::Logarithmic => format!("y = {a}·ln(x) {}", sb(self.b)),
            Form::Power => format!("y = {a}·x^{b}"),
        }
    }
}

fn fmt(v: f64) -> String {
    if v != 0.0 && (v.abs() >= 1e5 || v.abs() < 1e-3) {
        format!("{v:.4e}")
    } else {
        format!("{:.5}", v).trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

/// y = slope·x + intercept by least squares; None when x does not vary.
fn line(x: &[f64], y: &[f64]) -> Option<(f64, f64)> {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(u, v)| (u - mx) * (v - my)).sum();
    (sxx > 0.0).then(|| (sxy / sxx, my - sxy / sxx * mx))
}

fn r_squared(form: Form, a: f64, b: f64, x: &[f64], y: &[f64]) -> f64 {
    let my = y.iter().sum::<f64>() / y.len() as f64;
    let ss_tot: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
    let ss_res: f64 = x.iter().zip(y).map(|(u, v)| (v - form.eval(a, b, *u)).powi(2)).sum();
    if ss_tot > 0.0 {
        1.0 - ss_res / ss_tot
    } else if ss_res == 0.0 {
        1.0
    } else {
        f64::NEG_INFINITY
    }
}

/// Fits one form; says why when the data do not allow it (x ≤ 0 for a logarithm, y of
/// both signs for an exponential or power law).
pub fn fit(form: Form, x: &[f64], y: &[f64]) -> Result<Fit> {
    if x.len() != y.len() {
        return Err(CalibrationError::new(format!("{} x values and {} y values", x.len(), y.len())));
    }
    if x.len() < 3 {
        return Err(CalibrationError::new(format!(
            "{} point(s): a regression of two coefficients needs at least 3",
            x.len()
        )));
    }
    if let Some(i) = (0..x.len()).find(|&i| !(x[i].is_finite() && y[i].is_finite())) {
        return Err(CalibrationError::new(format!(
            "point {} is ({}, {}): every point must be finite",
            i + 1,
            x[i],
            y[i]
        )));
    }
    let needs_positive_x = matches!(form, Form::Logarithmic | Form::Power);
    if needs_positive_x && x.iter().any(|&v| v <= 0.0) {
        return Err(CalibrationError::new(format!("a {} fit needs every x > 0", form.name())));
    }
    let sign = if y[0] < 0.0 { -1.0 } else { 1.0 };
    let one_sign = y.iter().all(|&v| v * sign > 0.0);
    if matches!(form, Form::Exponential | Form::Power) && !one_sign {
        return Err(CalibrationError::new(format!("a {} fit needs every y non-zero and of one sign", form.name())));
    }
    let no_spread = || CalibrationError::new("x does not vary: nothing to regress on");
    let (a, b) = match form {
        Form::Linear => line(x, y).ok_or_else(no_spread)?,
        Form::Logarithmic => line(&x.iter().map(|v| v.ln()).collect::<Vec<_>>(), y).ok_or_else(no_spread)?,
        Form::Exponential | Form::Power => {
            let ly: Vec<f64> = y.iter().map(|v| (v * sign).ln()).collect();
            let lx: Vec<f64> = if form == Form::Power { x.iter().map(|v| v.ln()).collect() } else { x.to_vec() };
            let (s, i) = line(&lx, &ly).ok_or_else(no_spread)?;
            let start = [sign * i.exp(), s];
            let refined = minimise(
                |p| Ok(x.iter().zip(y).map(|(u, v)| form.eval(p[0], p[1], *u) - v).collect()),
                &start,
                &Options::unbounded(2),
            )
            .ok()
            .filter(|s| s.x.iter().all(|v| v.is_finite()));
            match refined {
                Some(s) => (s.x[0], s.x[1]),
                None => (start[0], start[1]),
            }
        }
    };
    Ok(Fit { form, a, b, r2: r_squared(form, a, b, x, y) })
}

/// Every form the data allow, best R² first.
pub fn fit_all(x: &[f64], y: &[f64]) -> Result<Vec<Fit>> {
    let mut fits = Vec::new();
    let mut why = Vec::new();
    for form in Form::ALL {
        match fit(form, x, y) {
            Ok(f) => fits.push(f),
            Err(e) => why.push(format!("{}: {e}", form.name())),
        }
    }
    if fits.is_empty() {
        return Err(CalibrationError::new(format!("no regression fits these data ({})", why.join("; "))));
    }
    fits.sort_by(|a, b| b.r2.total_cmp(&a.r2));
    Ok(fits)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn xs() -> Vec<f64> {
        (1..=9).map(|i| 0.5 + 0.125 * i as f64).collect()
    }

    #[test]
    fn each_form_recovers_the_coefficients_of_exact_data_and_is_chosen_best() {
        for (form, a, b) in [
            (Form::Linear, 5.0042, 36.675),
            (Form::Exponential, 50.8, 0.37),
            (Form::Logarithmic, 9.8722, 12.85),
            (Form::Power, 252.48, 0.42),
            (Form::Exponential, -2.0, -1.5),
        ] {
            let x = xs();
            let y: Vec<f64> = x.iter().map(|&v| form.eval(a, b, v)).collect();
            let f = fit(form, &x, &y).unwrap();
            assert!((f.a - a).abs() < 1e-9 * a.abs() && (f.b - b).abs() < 1e-9 * b.abs().max(1.0), "{form:?}: {f:?}");
            assert!((f.r2 - 1.0).abs() < 1e-12);
            let best = &fit_all(&x, &y).unwrap()[0];
            assert_eq!(best.form, form, "best of {:?}", fit_all(&x, &y).unwrap());
            // The inversion gives x back.
            assert!((f.invert(y[3]).unwrap() - x[3]).abs() < 1e-9);
        }
    }

    #[test]
    fn r2_of_a_noisy_line_matches_its_definition() {
        let x = xs();
        let y: Vec<f64> =
            x.iter().enumerate().map(|(i, v)| 2.0 * v + 1.0 + if i.is_multiple_of(2) { 0.05 } else { -0.05 }).collect();
        let f = fit(Form::Linear, &x, &y).unwrap();
        let my = y.iter().sum::<f64>() / 9.0;
        let tot: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
        let res: f64 = x.iter().zip(&y).map(|(u, v)| (v - f.predict(*u)).powi(2)).sum();
        assert!((f.r2 - (1.0 - res / tot)).abs() < 1e-14 && f.r2 < 1.0 && f.r2 > 0.9);
    }

    #[test]
    fn forms_the_data_cannot_take_are_refused_and_skipped() {
        let x = vec![-1.0, 0.0, 1.0, 2.0];
        let y = vec![1.0, -1.0, 2.0, 3.0];
        assert!(fit(Form::Logarithmic, &x, &y).unwrap_err().to_string().contains("x > 0"));
        assert!(fit(Form::Exponential, &x, &y).unwrap_err().to_string().contains("one sign"));
        let all = fit_all(&x, &y).unwrap();
        assert_eq!(all.len(), 1);
        assert!(Form::parse("cubic").unwrap_err().to_string().contains("linear, exponential"));
        // A flat fit and a y the form never reaches have no inversion.
        let flat = fit(Form::Linear, &[1.0, 2.0, 3.0], &[5.0; 3]).unwrap();
        assert!(flat.invert(6.0).unwrap_err().to_string().contains("is flat"));
        let exp = fit(Form::Exponential, &[1.0, 2.0, 3.0], &[2.0, 4.0, 8.0]).unwrap();
        assert!(exp.invert(-1.0).unwrap_err().to_string().contains("no x gives y = -1"));
        assert!(fit(Form::Linear, &[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0])
            .unwrap_err()
            .to_string()
            .contains("does not vary"));
    }
}
