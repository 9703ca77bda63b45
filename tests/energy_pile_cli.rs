//! The energy-pile example (examples/energy_pile) in quick mode through the CLI: a pile of
//! stiffer elements in a bonded soil, heated in stages with thermal expansion on (the
//! `conduction` stage), then the soil conducts; it writes its charts and pictures, the head
//! rises in proportion to the pile's temperature and below the free pile's α·ΔT·L/2, and the
//! warmed soil carries more stress.

use crate::common::*;

#[test]
fn energy_pile_quick_mode_raises_the_head_below_free_expansion_and_writes_its_charts() {
    let dir = temp_dir("energy_pile_quick");
    let out = dir.join("out");
    let (log, wall) = run_example_quick("energy_pile", &out);
    eprintln!("energy_pile quick mode: {wall:.1} s wall\n{log}");

    for name in [
        "head_vs_temperature",
        "head_vs_time",
        "ring_stress",
        "ring_temperature",
        "temperature",
        "heave",
        "stress_change",
    ] {
        for ext in ["svg", "png"] {
            let f = out.join(format!("{name}.{ext}"));
            let len = std::fs::metadata(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display())).len();
            assert!(len > 1000, "{} is only {len} bytes", f.display());
        }
    }
    for f in ["heating.csv", "hold.csv", "rings.csv", "metrics.csv"] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert!(
        log.contains("conduction(forward euler") && log.contains("thermal expansion"),
        "the plan lists the stage:\n{log}"
    );

    let m = metrics(&out);
    let get = |k: &str| *m.get(k).unwrap_or_else(|| panic!("metric {k} missing: {m:?}"));
    assert!(get("pile_elements") >= 10.0, "{m:?}");
    // The soil restrains the pile: the head rises, by less than a free pile's α·ΔT·L/2, and
    // the pile lengthens by less than α·ΔT·L. (Measured 0.38 and 0.27 of them.)
    let ratio = get("head_ratio_free");
    assert!(ratio > 0.1 && ratio < 1.0, "head rise / free pile's: {ratio}");
    let elong = get("elongation_ratio_free");
    assert!(elong > 0.05 && elong < 1.0, "elongation / α·ΔT·L: {elong}");
    // Warming the soil lifts it and the pile further, and raises the soil's stress next to the
    // pile (confined by the box's sides).
    assert!(get("head_rise_end") > get("head_rise_heating"), "{m:?}");
    assert!(get("ring1_temperature_rise") > 5.0 && get("ring1_temperature_rise") < get("delta_t"), "{m:?}");
    assert!(get("ring1_stress_change") > 0.02, "{m:?}");
    assert_eq!(get("broken_bonds"), 0.0, "the heating is elastic: {m:?}");

    // The head rises in proportion to the pile's temperature rise (an elastic response): each
    // stage's head over its rise within 5 % of the last stage's.
    let rise = csv_column(&out.join("heating.csv"), "temperature_rise");
    let head = csv_column(&out.join("heating.csv"), "head");
    let slope = head[head.len() - 1] / rise[rise.len() - 1];
    for (t, h) in rise.iter().zip(&head).skip(1) {
        assert!((h / t - slope).abs() < 0.05 * slope, "head {h} at +{t} K against slope {slope}: {head:?}");
    }
}
