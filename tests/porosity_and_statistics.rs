//! Field statistics and packing measures (issue 12 item 5): percentiles and histograms with
//! NumPy's conventions; porosity by volume fraction (a frictionless deposit's solid fraction
//! in an inner window lies in the random-packing band 0.55–0.66, and a window holding every
//! sphere whole gives exactly their volume); the coordination number without rattlers; bad
//! input refused by name.

use crate::common::{run_script, stderr, stdout, temp_dir};
use matdem_rs::api::Host;
use rhai::{Dynamic, Engine};
use std::rc::Rc;

fn engine(name: &str) -> Engine {
    matdem_rs::new_engine(Rc::new(Host::new(temp_dir(name))))
}

#[test]
fn percentiles_and_histograms_follow_numpy() {
    let e = engine("stats_numpy");
    let ok: bool = e
        .eval(
            "let f = field([7.0, 1.0, 10.0, 4.0, 2.0, 9.0, 3.0, 6.0, 5.0, 8.0]); \
             let p = f.percentiles([0, 25, 50, 90, 100]); \
             let h = f.histogram(3); let g = f.histogram([0.0, 2.0, 5.0]); \
             p[0] == 1.0 && p[1] == 3.25 && p[2] == 5.5 && (p[3] - 9.1).abs() < 1e-12 && p[4] == 10.0 \
               && f.median() == 5.5 && f.percentile(25) == 3.25 \
               && h.edges.to_array() == [1.0, 4.0, 7.0, 10.0] && h.counts.to_array() == [3.0, 3.0, 4.0] && h.outside == 0 \
               && g.counts.to_array() == [1.0, 4.0] && g.outside == 5 \
               && field([2.0, 2.0]).histogram(2).counts.to_array() == [0.0, 2.0]",
        )
        .unwrap();
    assert!(ok);
}

#[test]
fn bad_statistics_input_is_refused_by_name() {
    let e = engine("stats_refusals");
    for (script, words) in [
        ("field([1.0, 2.0]).percentile(101)", &["p = 101", "between 0 and 100"][..]),
        ("field([]).median()", &["median of an empty field"]),
        ("field([1.0, 0.0 / 0.0]).percentile(5)", &["element 1", "NaN"]),
        ("field([1.0, 2.0]).histogram(0)", &["0 bins"]),
        ("field([1.0, 2.0]).histogram([0.0, 2.0, 1.0])", &["edge 2", "strictly increasing"]),
        ("field([1.0, 2.0]).histogram([0.0])", &["at least 2 edges"]),
        ("field([1.0, 2.0]).histogram(\"ten\")", &["number of bins or an array of bin edges"]),
    ] {
        let err = e.eval::<Dynamic>(script).expect_err(script).to_string();
        for w in words {
            assert!(err.contains(w), "`{script}`: {err:?} lacks {w:?}");
        }
    }
}

/// A frictionless deposit (μp = 0 on grains and walls) settled under gravity: the solid
/// fraction of a window two diameters in from every side and below the top lies in the band
/// of random packings (random close packing 0.64; 0.55–0.66 allows for a loose start and a
/// 2 % accuracy of the window). The same packing's whole-sample window, holding every sphere
/// whole, gives exactly Σ V / V_box, and the centre-count of the old definition differs from
/// the volume fraction in the inner window.
#[test]
fn porosity_of_a_frictionless_deposition_window_by_volume_fraction() {
    let dir = temp_dir("stats_porosity");
    let script = r#"
let b = new_box("dep");
b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.005;
b.ball_r = 0.2e-3; b.distri_rate = 0.2; b.seed = 3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("glass", #{ kn: 2e4, ks: 8e3, mu_p: 0.0, r: 0.2e-3, restitution: 0.3 }));
d.set_standard_dt();
sediment(d, #{});
let D = 0.4e-3;
let top = (d.z + d.r).max();
let lo = [2.0 * D, 2.0 * D, 2.0 * D]; let hi = [0.004 - 2.0 * D, 0.004 - 2.0 * D, top - 2.0 * D];
let solid = 1.0 - d.porosity_box(lo, hi);
let inside = d.in_box(lo[0], hi[0], lo[1], hi[1], lo[2], hi[2]);
let vol = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
let centres = (d.r.select(inside) ** 3.0).sum() * 4.0 / 3.0 * PI() / vol;
let all_lo = [(d.x - d.r).min() - 1e-4, (d.y - d.r).min() - 1e-4, (d.z - d.r).min() - 1e-4];
let all_hi = [(d.x + d.r).max() + 1e-4, (d.y + d.r).max() + 1e-4, top + 1e-4];
let whole = 1.0 - d.porosity_box(all_lo, all_hi);
let v_all = (all_hi[0] - all_lo[0]) * (all_hi[1] - all_lo[1]) * (all_hi[2] - all_lo[2]);
let exact = (d.r ** 3.0).sum() * 4.0 / 3.0 * PI() / v_all;
let z = d.mechanical_coordination();
print(`result ${solid} ${centres} ${whole} ${exact} ${z.coordination} ${z.rattlers} ${d.coordination_number()} ${d.n}`);
"#;
    let o = run_script(&dir, "deposit.rhai", script, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let line = out.lines().find(|l| l.starts_with("result ")).unwrap_or_else(|| panic!("no result in {out}"));
    let v: Vec<f64> = line.split_whitespace().skip(1).map(|w| w.parse().unwrap()).collect();
    eprintln!(
        "solid fraction {} (centre count {}), whole-sample {} vs {}, Z without rattlers {} ({} rattlers), Z {} of {}",
        v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7]
    );
    assert!((0.55..=0.66).contains(&v[0]), "solid fraction {}", v[0]);
    assert!((v[2] / v[3] - 1.0).abs() < 1e-12, "whole-sample window {} vs Σ V / V_box {}", v[2], v[3]);
    assert!(v[0] != v[1], "the volume fraction differs from the centre count");
    // Frictionless grains at rest: about isostatic (6) once rattlers are out, never fewer
    // than the raw mean, which counts rattlers' zeros.
    assert!(v[4] >= v[6] && v[4] > 4.5 && v[4] < 7.0, "Z {} raw {}", v[4], v[6]);
}
