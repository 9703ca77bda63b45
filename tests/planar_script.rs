//! 2D models through the script API (issue 34 item 1): a box with `sample_l = 0` builds a
//! one-layer model in the x–z plane with the 2D lattice material, deposits in its plane,
//! measures porosity by area, pictures every element; `make_box(w, 0, h, r)` makes a hexagonal
//! layer; a 3D packing is refused by `d.make_2d()` with what to do instead.

use crate::common::{run_script, stderr, stdout, temp_dir};

#[test]
fn a_box_with_sample_l_0_builds_and_deposits_a_2d_model() {
    let dir = temp_dir("planar_script");
    let script = r#"
        let b = new_box("plate");
        b.sample_w = 0.01; b.sample_l = 0; b.sample_h = 0.008;
        b.ball_r = 0.25e-3; b.distri_rate = 0.2; b.seed = 3;
        b.set_type("top_platen");
        let d = b.build_initial_model();
        let mat = material_2d("rock", #{ E: 1e8, nu: 0.25, Tu: 1e5, Cu: 1e6, mu_i: 0.6, d: 0.5e-3 });
        let back = mat.macro_properties_2d(0.5e-3);
        print(`round trip ${(back.E / 1e8 - 1.0).abs() < 1e-12 && (back.nu - 0.25).abs() < 1e-12}`);
        d.set_group_mat("sample", mat);
        d.set_standard_dt();
        sediment(d, #{ accel: 30.0, tolerance: 0.05 });
        print(`dimension ${d.dimension()} thickness ${d.thickness()} n ${d.n}`);
        print(d.plan());
        print(`y ${d.y.abs().max()} vy ${d.vy.abs().max()}`);
        print(`porosity ${d.porosity_box([0.002, -1.0, 0.001], [0.008, 1.0, 0.004])}`);
        d.show("z", "plate");
        // A side wall's stress over the height × thickness the settled layer stands on it.
        let h = (d.z + d.r).max();
        let before = d.boundary("left").stress;
        d.set_boundary_area("left", h * d.thickness());
        print(`side area ${(d.boundary("left").area / (h * d.thickness()) - 1.0).abs() < 1e-12 && d.boundary("left").stress >= before}`);
        let q = plane_strain(#{ E: 1e8, nu: 0.2 });
        print(`plane strain ${(q.E / (1e8 / 0.96) - 1.0).abs() < 1e-12 && (q.nu - 0.25).abs() < 1e-12}`);
        let g = make_box(0.01, 0, 0.005, 0.25e-3);
        print(`layer ${g.n} ${g.y.abs().max()}`);
        let lining = make_annulus(2e-3, 3e-3, 0.25e-3);
        print(`lining ${lining.n > 20 && lining.y.abs().max() == 0.0 && ((lining.x * lining.x + lining.z * lining.z) ** 0.5).max() <= 2.75e-3 + 1e-12}`);
    "#;
    let out = run_script(&dir, "plate.rhai", script, &[]);
    let (so, se) = (stdout(&out), stderr(&out));
    assert!(out.status.success(), "{so}\n{se}");
    let line = |key: &str| so.lines().find(|l| l.starts_with(key)).unwrap_or_else(|| panic!("no `{key}` in\n{so}"));
    assert_eq!(line("round trip"), "round trip true");
    assert_eq!(line("plane strain"), "plane strain true");
    assert_eq!(line("side area"), "side area true");
    assert!(line("dimension").starts_with("dimension 2 thickness 0.000"), "{so}");
    assert!(so.contains("one layer of cells: 2D") && so.contains("2D: y held"), "{so}");
    assert_eq!(line("y "), "y 0.0 vy 0.0");
    let phi: f64 = line("porosity").split(' ').nth(1).unwrap().parse().unwrap();
    // By area: a 2D random packing of a narrow gradation; by volume it would read above 0.5.
    assert!((0.1..0.3).contains(&phi), "porosity by area {phi}");
    // A 20 × 10-diameter hexagonal layer: 11 rows (spaced √3/2·d) of 20 and 19 alternately.
    assert_eq!(line("layer"), "layer 215 0.0");
    assert_eq!(line("lining"), "lining true");
    for ext in ["svg", "png"] {
        assert!(dir.join("out").join(format!("plate.{ext}")).exists(), "plate.{ext} not written");
    }
}

#[test]
fn a_3d_packing_is_refused_as_2d_and_a_3d_material_refuses_a_2d_poisson_ratio() {
    let dir = temp_dir("planar_refusals");
    let out = run_script(
        &dir,
        "flat.rhai",
        r#"
        let b = new_box("cube");
        b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.4e-3;
        let d = b.build_initial_model();
        d.make_2d();
        "#,
        &[],
    );
    let se = stderr(&out);
    assert!(!out.status.success() && se.contains("sample_l = 0") && se.contains("y = "), "{se}");
    let out = run_script(
        &dir,
        "nu.rhai",
        r#"material("rock", #{ E: 1e8, nu: 0.25, Tu: 1e5, Cu: 1e6, mu_i: 0.6, d: 0.5e-3 });"#,
        &[],
    );
    let se = stderr(&out);
    assert!(!out.status.success() && se.contains("0.2"), "{se}");
}

#[test]
fn a_2d_test_sample_runs_lab_tests_and_trains_from_the_2d_formulas() {
    let dir = temp_dir("planar_training");
    let script = r#"
        let m = material_2d("soil", #{ E: 5e7, nu: 0.25, Tu: 2e4, Cu: 2e5, mu_i: 0.6, d: 2e-3, density: 2000.0 });
        let s = test_sample(m, #{ elements: 200, dimension: 2 });
        let r = s.lab_test("uniaxial_compression", #{});
        print(`ucs E ${r.E} nu ${r.nu} peak ${r.peak_stress}`);
        let t = train(#{ name: "soil_2d", E: 5e7, nu: 0.25, Tu: 2e4, Cu: 2e5, mu_i: 0.6, density: 2000.0 },
                      #{ elements: 200, dimension: 2, rounds: 1, quiet: true });
        print(`trained ${t.elements}`);
    "#;
    let out = run_script(&dir, "train2d.rhai", script, &[]);
    let (so, se) = (stdout(&out), stderr(&out));
    assert!(out.status.success(), "{so}\n{se}");
    let ucs: Vec<f64> = so
        .lines()
        .find(|l| l.starts_with("ucs"))
        .unwrap_or_else(|| panic!("{so}"))
        .split(' ')
        .filter_map(|w| w.parse().ok())
        .collect();
    // A random layer of the lattice material: E within a factor 5, ν within the 2D range.
    assert!(ucs[0] > 1e7 && ucs[0] < 2.5e8 && (0.0..0.5).contains(&ucs[1]) && ucs[2] > 0.0, "{so}");
    let trained: f64 = so.lines().find_map(|l| l.strip_prefix("trained ")).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    assert!((150.0..260.0).contains(&trained), "{so}");
    // ν 0.25 is beyond the 3D formulas: refused without dimension 2; a dimension of 4 too.
    let refused = run_script(
        &dir,
        "train3d.rhai",
        r#"train(#{ E: 5e7, nu: 0.25, Tu: 2e4, Cu: 2e5, mu_i: 0.6 }, #{ elements: 200, rounds: 1 });"#,
        &[],
    );
    assert!(!refused.status.success() && stderr(&refused).contains("0.2"), "{}", stderr(&refused));
    let refused = run_script(
        &dir,
        "train4d.rhai",
        r#"train(#{ E: 5e7, nu: 0.1, Tu: 2e4, Cu: 2e5, mu_i: 0.6 }, #{ dimension: 4 });"#,
        &[],
    );
    assert!(!refused.status.success() && stderr(&refused).contains("2 or 3"), "{}", stderr(&refused));
    let refused = run_script(
        &dir,
        "area.rhai",
        r#"let b = new_box("t"); let d = b.build_initial_model(); d.set_boundary_area("bottom", -1.0);"#,
        &[],
    );
    assert!(!refused.status.success() && stderr(&refused).contains("> 0 m²"), "{}", stderr(&refused));
    // A 2D model's elements stay in its plane.
    let refused = run_script(
        &dir,
        "off_plane.rhai",
        r#"let b = new_box("t"); b.sample_l = 0; b.sample_h = 0.01; b.ball_r = 1e-3; let d = b.build_initial_model(); d.set("y", [0], 1e-4);"#,
        &[],
    );
    assert!(!refused.status.success() && stderr(&refused).contains("is 2D"), "{}", stderr(&refused));
}
