//! The periodic simple shear example (examples/periodic_shear.rhai) in quick mode through the
//! CLI: a layer repeating along x and y, sheared between rough boundaries of its own grains under
//! a servo platen. It writes its table and charts; the servo holds σn; the layer's stress ratio
//! rises from zero to a friction that spheres of μ_p = 0.5 with free rotation show (measured
//! 2026-12-06 in quick mode: peak 0.57, residual 0.42, σn within 19 % — 165 grains, where one
//! force chain's collapse unloads the platen before the servo follows).

use crate::common::*;
use std::path::Path;

#[test]
fn periodic_shear_quick_mode_shears_the_layer_at_its_friction() {
    let dir = temp_dir("periodic_shear_quick");
    let out = dir.join("out");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/periodic_shear.rhai");
    let o = bin().arg("run").arg(&script).args(["--set", "quick=true", "--out"]).arg(&out).output().unwrap();
    assert!(o.status.success(), "{}\n{}", stdout(&o), stderr(&o));
    eprintln!("{}", stdout(&o));
    for name in ["stress_ratio", "dilation"] {
        for ext in ["svg", "png"] {
            assert!(out.join(format!("{name}.{ext}")).is_file(), "{name}.{ext} missing");
        }
    }
    let m = metrics(&out);
    let (peak, residual) = (m["peak_ratio"], m["residual_ratio"]);
    assert!((0.25..0.8).contains(&peak) && (0.15..=peak).contains(&residual), "τ/σn peak {peak}, residual {residual}");
    let sigma = csv_column(&out.join("shear.csv"), "sigma_n");
    assert!(sigma.iter().all(|s| (s / 100e3 - 1.0).abs() < 0.25), "σn held within 25 %: {sigma:?}");
    let ratio = csv_column(&out.join("shear.csv"), "stress_ratio");
    assert!(ratio[0] < peak, "the ratio rises from the start: {ratio:?}");
}
