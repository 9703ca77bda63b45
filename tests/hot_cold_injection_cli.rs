//! The hot and cold injection example (examples/hot_cold_injection) in quick mode through the
//! CLI: a frozen three-layer slab, pore flow with heat, hot and cold wells and a drain. It
//! writes its charts, pictures and the pore network for ParaView; the heat books close (what
//! grains and fluid gained is what the wells and the drain supplied); the hot water warms the
//! upper layer and the cold water cools the lower one.

use crate::common::*;

#[test]
fn hot_cold_injection_quick_mode_warms_the_upper_layer_cools_the_lower_and_closes_its_books() {
    let dir = temp_dir("hot_cold_injection_quick");
    let out = dir.join("out");
    let (log, wall) = run_example_quick("hot_cold_injection", &out);
    eprintln!("hot/cold injection quick mode: {wall:.1} s wall\n{log}");

    let mut pictures = vec!["mass", "energy", "layer_temperature", "layers", "fluid_temperature", "pore_pressure"];
    pictures.extend(["temperature_1", "temperature_4"]);
    for name in pictures {
        for ext in ["svg", "png"] {
            let f = out.join(format!("{name}.{ext}"));
            let len = std::fs::metadata(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display())).len();
            assert!(len > 1000, "{} is only {len} bytes", f.display());
        }
    }
    for f in ["history.csv", "metrics.csv", "pores_final.vtp"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let vtp = std::fs::read_to_string(out.join("pores_final.vtp")).unwrap();
    assert!(vtp.contains("Name=\"temperature\"") && vtp.contains("Name=\"flux\""));
    let m = metrics(&out);
    let get = |k: &str| *m.get(k).unwrap_or_else(|| panic!("metric {k} missing: {m:?}"));
    // The books close to round-off (accumulated over some 10⁵ sub-steps).
    assert!(get("energy_balance_error") < 1e-9, "{m:?}");
    // Both wells inject; the drain takes it (the pressure field was steady before).
    assert!(get("hot_mass") > 0.0 && get("cold_mass") > 0.0 && get("drained_mass") > 0.0, "{m:?}");
    // Hot above, cold below: the upper layer ends warmer than 20 °C, the lower cooler.
    assert!(get("upper_c") > 20.5 && get("lower_c") < 19.8, "{m:?}");
    assert!(get("upper_c") > get("middle_c") && get("middle_c") > get("lower_c"), "{m:?}");
}
