//! The direct shear test from a script (`stdlib_scripts/direct_shear.rhai`, docs/direct-shear.md):
//! a small box of grains deposited, split into two half-boxes of plane strips, consolidated and
//! sheared under a servo platen. Proves: the normal stress stays within 1 % of its target over
//! every recorded interval while shearing (with the contact dashpot on); the upper box's push balances the
//! lower box's reaction (quasi-static force balance); a frictional packing is stronger than a
//! frictionless one (peak τ/σ rises with μ); the Mohr–Coulomb fit of peaks at three normal
//! stresses; bad inputs refused with messages that say what to do.

use matdem_rs::api::Host;
use std::rc::Rc;

fn engine(dir: &std::path::Path) -> rhai::Engine {
    matdem_rs::new_engine(Rc::new(Host::new(dir.to_path_buf())))
}

/// ~330 grains (r 0.4–0.6 mm) in an 8 × 5 × 6 mm box deposited under gravity and saved as
/// `sample` in the run's folder; `MU` is the grains' friction.
fn sample(mu: f64) -> String {
    format!(
        r#"
let b = new_box("shear");
b.sample_w = 0.008; b.sample_l = 0.005; b.sample_h = 0.006;
b.ball_r = 0.5e-3; b.distri_rate = 0.2; b.seed = 11;
b.set_type("top_platen");
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("sand", #{{ kn: 1e5, ks: 4e4, mu_p: {mu}, r: 0.5e-3, restitution: 0.3 }}));
d.set_standard_dt();
sediment(d, #{{ accel: 30.0, tolerance: 0.05 }});
d.place_boundary("top_platen", [0.0, 0.0, (d.z + d.r).max()]);
let area = shear_box(d, 0.5 * (d.z + d.r).max(), 0.0, #{{}});
"#
    )
}

/// Shears the sample at `sigma` for 0.8 mm in 16 rows; returns the table's columns and the peak.
const SHEAR: &str = r#"
let t = direct_shear(d, area, SIGMA, #{ displacement: 0.8e-3, rows: 16, tolerance: 0.05 });
let p = shear_peak(t);
#{ n: d.n, normal_error: t["normal_error_max"].max(), sigma_rows: t["normal_stress"].to_array(), tau: t["shear_stress"].to_array(),
   lower: t["lower_shear_stress"].to_array(), dilation: t["dilation"].to_array(), disp: t["shear_displacement"].to_array(), peak_ratio: p.tau / p.sigma, peak: p.tau, sigma: p.sigma,
   rows: t.rows }
"#;

fn shear(mu: f64, sigma: f64, name: &str) -> rhai::Map {
    let dir = crate::common::temp_dir(name);
    let e = engine(&dir);
    let script = format!("{}{}", sample(mu), SHEAR.replace("SIGMA", &format!("{sigma:e}")));
    let clock = std::time::Instant::now();
    let out: rhai::Map = e.eval(&script).unwrap_or_else(|err| panic!("{err}"));
    eprintln!("{name}: {} grains, {:.1} s", out["n"], clock.elapsed().as_secs_f64());
    out
}

fn floats(v: &rhai::Dynamic) -> Vec<f64> {
    v.clone().into_array().unwrap().iter().map(|x| x.as_float().unwrap()).collect()
}

#[test]
fn direct_shear_holds_the_normal_stress_and_balances_the_shear_force() {
    let out = shear(0.5, 100e3, "direct_shear_balance");
    // Each row's normal stress (the platen's, averaged over its checks every 50 steps) within
    // 1 % of the target; single checks jump a few % while grains under the platen rearrange.
    let sigma = floats(&out["sigma_rows"]);
    let worst_row = sigma.iter().map(|s| (s / 100e3 - 1.0).abs()).fold(0.0, f64::max);
    let err = out["normal_error"].as_float().unwrap();
    eprintln!(
        "normal stress while shearing: rows within {:.2} % of the target, single checks within {:.2} %",
        100.0 * worst_row,
        100.0 * err
    );
    assert!(worst_row < 0.01, "a row's normal stress is off its target by {:.2} %", 100.0 * worst_row);
    assert!(err < 0.1, "a check's normal stress is off its target by {:.2} %", 100.0 * err);
    let (tau, lower, disp) = (floats(&out["tau"]), floats(&out["lower"]), floats(&out["disp"]));
    let peak = out["peak"].as_float().unwrap();
    assert!(peak > 0.2 * 100e3, "a frictional packing resists shear: peak τ {peak:.0} Pa");
    // The upper box's push and the lower box's reaction: equal and opposite but for the
    // grains' inertia and the local damping, averaged over the rows (each row's loads are
    // means over its checks; measured 2.4 kPa against a 156 kPa peak).
    let imbalance: f64 = tau.iter().zip(&lower).map(|(t, l)| (t - l).abs()).sum::<f64>() / tau.len() as f64;
    eprintln!("mean |τ_upper − τ_lower| {imbalance:.1} Pa against a peak of {peak:.0} Pa");
    assert!(imbalance < 0.05 * peak, "force balance off by {imbalance:.1} Pa (peak {peak:.0} Pa)");
    // The upper box moved the asked distance at a constant speed.
    let last = *disp.last().unwrap();
    assert!((last - 0.8e-3).abs() < 0.01 * 0.8e-3, "sheared {last} m");
    assert!(disp.windows(2).all(|w| w[1] > w[0]));
}

#[test]
fn peak_stress_ratio_rises_with_grain_friction() {
    let smooth = shear(0.0, 100e3, "direct_shear_mu0")["peak_ratio"].as_float().unwrap();
    let rough = shear(0.5, 100e3, "direct_shear_mu05")["peak_ratio"].as_float().unwrap();
    eprintln!("peak τ/σ: μ = 0 → {smooth:.3}, μ = 0.5 → {rough:.3}");
    assert!(rough > smooth + 0.1, "peak τ/σ μ=0: {smooth:.3}, μ=0.5: {rough:.3}");
}

#[test]
fn shear_box_and_direct_shear_refuse_bad_inputs() {
    let dir = crate::common::temp_dir("direct_shear_refusals");
    let e = engine(&dir);
    let fails = |script: &str| -> String {
        let full = format!("{}\n{script}", crate::common::SMALL_BOX);
        match e.eval::<rhai::Dynamic>(&full) {
            Ok(v) => panic!("`{script}` should fail, returned {v}"),
            Err(err) => err.to_string(),
        }
    };
    let m = fails("direct_shear(d, 1e-5, 100e3, #{})");
    assert!(m.contains("call shear_box"), "{m}");
    let m = fails("shear_box(d, 1.0, 0.0, #{})");
    assert!(m.contains("must lie between the bottom"), "{m}");
    let m = fails("shear_box(d, 0.001, -0.001, #{})");
    assert!(m.contains("gap"), "{m}");
    let m = fails("let a = shear_box(d, 0.0015, 0.0, #{}); direct_shear(d, a, -5.0, #{})");
    assert!(m.contains("normal stress must be a number > 0"), "{m}");
    let m = fails("let a = shear_box(d, 0.0015, 0.0, #{}); direct_shear(d, a, 1e5, #{ speed: -1.0 })");
    assert!(m.contains("must be > 0"), "{m}");
    let m = fails("d.set_platen_stress(\"top_platen\", 0.0 / 0.0)");
    assert!(m.contains("platen stress must be a finite number of Pa"), "{m}");
    let m = fails("let a = shear_box(d, 0.0015, 0.0, #{}); d.set_platen_stress(\"upper_left\", 1e5)");
    assert!(m.contains("is a strip") && m.contains("move_boundary"), "{m}");
    let m =
        fails("d.add_strip(#{ name: \"s\", point: [0, 0, 0], normal: [1, 0, 0], axis: [1, 0, 0], from: 0, to: 1 })");
    assert!(m.contains("axis must lie in the plane"), "{m}");
    let m =
        fails("d.add_strip(#{ name: \"s\", point: [0, 0, 0], normal: [1, 0, 0], axis: [0, 0, 1], from: 1, to: 0 })");
    assert!(m.contains("lo < hi"), "{m}");
    let m = fails("d.add_strip(#{ name: \"s\", point: [0, 0, 0], normal: [1, 0, 0], axs: [0, 0, 1], from: 0, to: 1 })");
    assert!(m.contains("axs"), "{m}");
    let m = fails("d.limit_boundary(\"nowhere\", [0, 0, 1], 0.0, 1.0)");
    assert!(m.contains("nowhere"), "{m}");
    // A model without a shear box's walls.
    let m = fails("let m2 = new_model(\"empty\"); shear_box(m2, 0.001, 0.0, #{})");
    assert!(m.contains("no wall 'bottom'") && m.contains("set_type"), "{m}");
}

#[test]
fn shear_peak_takes_the_largest_running_mean_over_a_window_of_rows() {
    let dir = crate::common::temp_dir("direct_shear_peak_window");
    let e = engine(&dir);
    // A record with a one-row spike (row 1, 150 kPa) before a broad hump (rows 4–6): the plain
    // peak is the spike; the peak over 3 rows is the hump's mean (90 + 100 + 95)/3 = 95 kPa,
    // centred on row 5, with the mean normal stress of those rows.
    let script = r#"
let t = new_table();
let tau = [60e3, 150e3, 40e3, 50e3, 90e3, 100e3, 95e3, 60e3];
let sig = [100e3, 101e3, 99e3, 100e3, 102e3, 98e3, 100e3, 100e3];
for k in 0..8 {
    t.add_row(#{ shear_displacement: 5e-5 * (k + 1), shear_stress: tau[k], normal_stress: sig[k] });
}
let one = shear_peak(t);
let same = shear_peak(t, #{ window: 1 });
let three = shear_peak(t, #{ window: 3 });
let all = shear_peak(t, #{ window: 8 });
[one.tau, one.row, same.tau, three.tau, three.sigma, three.row, three.displacement, all.tau]
"#;
    let v: Vec<f64> = e
        .eval::<rhai::Array>(script)
        .unwrap_or_else(|err| panic!("{err}"))
        .iter()
        .map(|x| x.as_float().unwrap_or_else(|_| x.as_int().unwrap() as f64))
        .collect();
    assert_eq!((v[0], v[1], v[2]), (150e3, 1.0, 150e3), "{v:?}");
    assert!((v[3] - 95e3).abs() < 1e-9, "window 3: {v:?}");
    assert!((v[4] - 100e3).abs() < 1e-9, "window 3's normal stress: {v:?}");
    assert_eq!(v[5], 5.0, "{v:?}");
    assert!((v[6] - 3e-4).abs() < 1e-12, "{v:?}");
    assert!((v[7] - 645e3 / 8.0).abs() < 1e-9, "the whole record's mean: {v:?}");
    for bad in ["0", "9", "1.5"] {
        let err = e
            .eval::<rhai::Dynamic>(&format!("{script}; shear_peak(t, #{{ window: {bad} }})"))
            .map(|v| panic!("window {bad} accepted: {v}"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("window must be a whole number of rows from 1 to the record's 8"), "{err}");
    }
}
