//! The land-subsidence example (examples/land_subsidence) in quick mode through the CLI: a
//! bonded column of sand, clay and sand under a water table (the `buoyancy` stage), the table
//! lowered in stages; it writes its charts and pictures, the surface settles more at every
//! stage, by what the effective-stress estimate Σ Δσ'·h/M gives with the layers' measured
//! moduli, and the soft clay takes most of it.

use crate::common::*;

#[test]
fn land_subsidence_quick_mode_settles_the_ground_as_the_effective_stress_estimate() {
    let dir = temp_dir("land_subsidence_quick");
    let out = dir.join("out");
    let (log, wall) = run_example_quick("land_subsidence", &out);
    eprintln!("land_subsidence quick mode: {wall:.1} s wall\n{log}");

    for name in ["settlement_vs_depth", "settlement_vs_time", "settlement_vs_estimate", "layers", "settlement"] {
        for ext in ["svg", "png"] {
            let f = out.join(format!("{name}.{ext}"));
            let len = std::fs::metadata(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display())).len();
            assert!(len > 1000, "{} is only {len} bytes", f.display());
        }
    }
    for f in ["moduli.csv", "stages.csv", "markers.csv", "settlement_history.csv", "metrics.csv"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(log.contains("buoyancy(water level"), "the plan lists the stage:\n{log}");

    let m = metrics(&out);
    let get = |k: &str| *m.get(k).unwrap_or_else(|| panic!("metric {k} missing: {m:?}"));
    // The clay is the soft layer (measured: 8.5 MPa against 36 and 34 MPa for the sands).
    assert!(get("modulus_clay") < 0.5 * get("modulus_lower_sand").min(get("modulus_upper_sand")), "{m:?}");
    // Filling the table lifts the ground (buoyancy unloads it); pumping settles it.
    assert!(get("swell_on_filling") > 0.0, "{m:?}");
    assert!(get("stages") >= 3.0 && get("surface_settlement") > 0.0, "{m:?}");
    // The surface settles by the effective-stress estimate with the elements' buoyancy and the
    // measured moduli within 5 % (measured 0.4 % less), well under the textbook ρ_w·g·Δh's
    // (which counts the pores' water, which the elements do not hold).
    let ratio = get("settlement_ratio");
    assert!((ratio - 1.0).abs() < 0.05, "DEM / estimate {ratio}: {m:?}");
    assert!(get("surface_settlement") < 0.8 * get("textbook_settlement"), "{m:?}");
    assert!(get("clay_share") > 0.5, "the clay takes most of the settlement: {m:?}");
    assert_eq!(get("broken_bonds"), 0.0, "{m:?}");

    // The surface settles further at every stage, and each stage by its estimate within 10 %
    // (measured within 1 %).
    let stages = out.join("stages.csv");
    let surface = csv_column(&stages, "surface");
    assert!(surface.windows(2).all(|p| p[1] > p[0]), "{surface:?}");
    let (ds, de) = (csv_column(&stages, "stage_settlement"), csv_column(&stages, "stage_estimate"));
    for (s, e) in ds.iter().zip(&de).skip(1) {
        assert!((s / e - 1.0).abs() < 0.10, "stage settlement {s} against its estimate {e}");
    }
}
