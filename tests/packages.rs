//! Packaged simulators: `info` describes the parameters, `run --set` checks values against
//! the manifest before anything runs, and `pack` makes one archive that `run` and `info`
//! take as is — the oedometer gives the same results from its folder and from its archive.

use crate::common::*;
use std::path::{Path, PathBuf};

fn oedometer() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/oedometer")
}

/// A tiny package: `n` (int, default 41), `x` (float in 0 … 10), `flag` (bool), `label`.
fn tiny_package(dir: &Path) -> PathBuf {
    let pkg = dir.join("tiny");
    std::fs::create_dir_all(pkg.join("data")).unwrap();
    std::fs::write(
        pkg.join("simulator.ron"),
        r#"(name: "tiny", version: "1.2.0", description: "adds one", entry: "main.rhai",
            parameters: [
                (name: "n", type: int, default: 41, help: "a count"),
                (name: "x", type: float, default: 1, unit: "m", range: (0.0, 10.0), help: "a length"),
                (name: "flag", type: bool, default: false),
                (name: "label", type: string),
            ],
            outputs: ["sum.csv"])"#,
    )
    .unwrap();
    std::fs::write(
        pkg.join("main.rhai"),
        r#"import "helpers" as h;
           let t = load_table("data/input.csv");
           print(`${h::plus_one(params.n)} ${type_of(params.x)} ${params.x} ${params.flag} ${params.label ?? "unset"} ${t["a"].sum()}`);
           t.save("sum.csv");"#,
    )
    .unwrap();
    std::fs::write(pkg.join("helpers.rhai"), "fn plus_one(n) { n + 1 }").unwrap();
    std::fs::write(pkg.join("data/input.csv"), "a,b\n1.5,2\n2.5,3\n").unwrap();
    pkg
}

#[test]
fn info_prints_each_parameter_with_type_default_unit_range_and_help() {
    let o = bin().arg("info").arg(oedometer()).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.starts_with("oedometer 0.1.0 — Confined (oedometer) compression"), "{out}");
    let row = |name: &str| {
        out.lines().find(|l| l.starts_with(&format!("{name} "))).unwrap_or_else(|| panic!("no row {name}:\n{out}"))
    };
    let dt = row("dt_rate");
    for cell in ["float", "1.0", "× standard dt", "0.05 … 10", "multiple of MatDEM's standard step"] {
        assert!(dt.contains(cell), "dt_rate row lacks `{cell}`: {dt}");
    }
    assert!(row("quick").contains("bool") && row("quick").contains("false"));
    assert!(row("seed").contains("int") && row("seed").contains("1000"));
    assert!(row("ring_mm").contains("(unset)") && row("ring_mm").contains("mm"));
    assert!(out.contains("outputs:") && out.contains("stages_all.csv"), "{out}");
}

#[test]
fn bad_values_are_refused_before_anything_runs_with_the_allowed_range() {
    let dir = temp_dir("pkg_bad_values");
    let out = dir.join("never_created");
    let run = |set: &str| bin().arg("run").arg(oedometer()).args(["--set", set, "--out"]).arg(&out).output().unwrap();
    let cases = [
        ("dt_rate=50", "--set dt_rate=50: out of range; `dt_rate` [× standard dt] is a float within 0.05 … 10"),
        ("dt_rate=fast", "`fast` is not a finite number"),
        ("dt_rate=inf", "`inf` is not a finite number"),
        ("seed=1.5", "`1.5` is not an integer; `seed` is an int within 0 … 1000000000"),
        ("quick=yes", "`yes` is not a bool; `quick` is a bool: true or false"),
        ("ring=3", "has no parameter `ring` (did you mean `ring_mm`?); its parameters: quick, full, ring_mm"),
        ("=3", "--set expects NAME=VALUE"),
    ];
    for (set, expected) in cases {
        let o = run(set);
        assert_eq!(o.status.code(), Some(2), "--set {set}: {}", stderr(&o));
        assert!(stderr(&o).contains(expected), "--set {set}: expected `{expected}` in:\n{}", stderr(&o));
        assert!(stderr(&o).contains("nothing was run"), "{}", stderr(&o));
        assert!(!out.exists(), "--set {set}: the output folder must not be created");
    }
}

#[test]
fn defaults_and_set_values_reach_the_script_typed_with_its_imports_and_data() {
    let dir = temp_dir("pkg_tiny");
    let pkg = tiny_package(&dir);
    let o = bin().arg("run").arg(&pkg).arg("--out").arg(dir.join("out")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "42 f64 1.0 false unset 4.0");
    let o = bin()
        .arg("run")
        .arg(&pkg)
        .args(["--set", "n=9", "--set", "x=2", "--set", "flag=true", "--set", "label=hi", "--out"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "10 f64 2.0 true hi 4.0");
    assert!(dir.join("out/sum.csv").is_file());
}

#[test]
fn a_string_parameter_with_choices_takes_only_those_and_says_which() {
    let dir = temp_dir("pkg_choices");
    let pkg = dir.join("choices");
    std::fs::create_dir_all(&pkg).unwrap();
    let manifest = |choices: &str, default: &str| {
        format!(
            r#"(name: "c", version: "1", description: "d", entry: "m.rhai",
                parameters: [(name: "law", type: string, default: {default}, choices: {choices}, help: "contact law")])"#
        )
    };
    std::fs::write(pkg.join("m.rhai"), "print(params.law);").unwrap();
    std::fs::write(pkg.join("simulator.ron"), manifest(r#"["hertz", "linear"]"#, r#""hertz""#)).unwrap();
    let run = |set: &[&str]| bin().arg("run").arg(&pkg).args(set).arg("--out").arg(dir.join("out")).output().unwrap();

    let o = run(&[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "hertz");
    let o = run(&["--set", "law=linear"]);
    assert_eq!(stdout(&o).trim(), "linear", "{}", stderr(&o));
    let o = run(&["--set", "law=hertzz"]);
    assert_eq!(o.status.code(), Some(2));
    let expected = "--set law=hertzz: `hertzz` is not one of the choices (did you mean `hertz`?); \
                    `law` is one of `hertz`, `linear` (contact law)";
    assert!(stderr(&o).contains(expected), "expected `{expected}` in:\n{}", stderr(&o));
    let info = bin().arg("info").arg(&pkg).output().unwrap();
    assert!(stdout(&info).contains("hertz | linear"), "{}", stdout(&info));

    // The manifest itself is checked: a default outside the choices, a repeated choice.
    for (choices, default, why) in [
        (r#"["hertz"]"#, r#""linear""#, "`linear` is not one of the choices"),
        (r#"["a", "a"]"#, r#""a""#, "choices need a string type and distinct, non-empty values"),
    ] {
        std::fs::write(pkg.join("simulator.ron"), manifest(choices, default)).unwrap();
        let o = run(&[]);
        assert_eq!(o.status.code(), Some(2), "{choices}");
        assert!(stderr(&o).contains(why), "{choices}: expected `{why}` in:\n{}", stderr(&o));
    }
}

#[test]
fn a_packed_archive_runs_as_is_and_packing_is_reproducible() {
    let dir = temp_dir("pkg_tiny_archive");
    let pkg = tiny_package(&dir);
    let tar = dir.join("tiny.tar");
    let o = bin().arg("pack").arg(&pkg).arg("-o").arg(&tar).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("packed 4 file(s)"), "{}", stderr(&o));
    let first = std::fs::read(&tar).unwrap();
    assert!(bin().arg("pack").arg(&pkg).arg("-o").arg(&tar).status().unwrap().success());
    assert_eq!(first, std::fs::read(&tar).unwrap(), "the same folder packs to the same bytes");

    // Moved away from its folder, the archive alone is enough.
    std::fs::remove_dir_all(&pkg).unwrap();
    let info = bin().arg("info").arg(&tar).output().unwrap();
    assert!(stdout(&info).starts_with("tiny 1.2.0 — adds one"), "{}", stderr(&info));
    let o = bin().arg("run").arg(&tar).args(["--set", "n=1", "--out"]).arg(dir.join("out")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "2 f64 1.0 false unset 4.0");
    let entries: Vec<String> =
        std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    assert_eq!(entries.len(), 2, "running an archive extracts nothing: {entries:?}");
}

#[test]
fn an_archive_with_a_link_or_an_escaping_entry_is_refused() {
    let dir = temp_dir("pkg_evil_archive");
    let write = |name: &str, build: &dyn Fn(&mut tar::Builder<Vec<u8>>)| {
        let mut b = tar::Builder::new(Vec::new());
        let mut h = tar::Header::new_ustar();
        let manifest = br#"(name: "e", version: "0", description: "", entry: "m.rhai")"#;
        h.set_size(manifest.len() as u64);
        h.set_mode(0o644);
        b.append_data(&mut h, "simulator.ron", &manifest[..]).unwrap();
        build(&mut b);
        let path = dir.join(name);
        std::fs::write(&path, b.into_inner().unwrap()).unwrap();
        path
    };
    let link = write("link.tar", &|b| {
        let mut h = tar::Header::new_ustar();
        h.set_entry_type(tar::EntryType::Symlink);
        h.set_size(0);
        b.append_link(&mut h, "m.rhai", "/etc/passwd").unwrap();
    });
    let o = bin().arg("run").arg(&link).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("m.rhai is not a plain file (a link or device)"), "{}", stderr(&o));
    let escape = write("escape.tar", &|b| {
        let mut h = tar::Header::new_old();
        // The builder refuses `..`; a hostile archive is written by hand.
        h.as_old_mut().name[..12].copy_from_slice(b"../../m.rhai");
        h.set_size(1);
        h.set_mode(0o644);
        h.set_cksum();
        b.append(&h, &b"1"[..]).unwrap();
    });
    let o = bin().arg("info").arg(&escape).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("entry ../../m.rhai leaves the archive"), "{}", stderr(&o));
}

#[test]
fn an_archive_with_a_duplicate_entry_or_two_manifests_is_refused() {
    let dir = temp_dir("pkg_duplicates");
    let archive = |name: &str, entries: &[(&str, &str)]| {
        let mut b = tar::Builder::new(Vec::new());
        for (path, text) in entries {
            let mut h = tar::Header::new_ustar();
            h.set_size(text.len() as u64);
            h.set_mode(0o644);
            b.append_data(&mut h, path, text.as_bytes()).unwrap();
        }
        let path = dir.join(name);
        std::fs::write(&path, b.into_inner().unwrap()).unwrap();
        path
    };
    let manifest = r#"(name: "d", version: "0", description: "", entry: "m.rhai")"#;
    let twice = archive(
        "twice.tar",
        &[("simulator.ron", manifest), ("m.rhai", "print(\"first\");"), ("./m.rhai", "print(\"second\");")],
    );
    let o = bin().arg("run").arg(&twice).arg("--out").arg(dir.join("out")).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("holds `m.rhai` twice"), "{}", stderr(&o));
    assert!(!stdout(&o).contains("first") && !stdout(&o).contains("second"));

    let two = archive(
        "two_manifests.tar",
        &[("simulator.ron", manifest), ("m.rhai", "print(1);"), ("inner/simulator.ron", manifest)],
    );
    let o = bin().arg("info").arg(&two).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("holds 2 manifests (inner/simulator.ron, simulator.ron)"), "{}", stderr(&o));

    // Files beside the one top folder would be dropped without a word: refused too.
    let beside = archive(
        "beside.tar",
        &[("pkg/simulator.ron", manifest), ("pkg/m.rhai", "print(1);"), ("stray.rhai", "print(2);")],
    );
    let o = bin().arg("info").arg(&beside).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("nor one top folder holding it and everything else"), "{}", stderr(&o));
}

#[test]
fn pack_never_replaces_a_device_a_pipe_or_a_link() {
    let dir = temp_dir("pkg_special_target");
    let pkg = tiny_package(&dir);
    let fifo = dir.join("fifo");
    assert!(std::process::Command::new("mkfifo").arg(&fifo).status().unwrap().success());
    for target in [fifo.as_path(), Path::new("/dev/full")] {
        let o = bin().arg("pack").arg(&pkg).arg("-o").arg(target).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("is not a regular file; refusing to replace it"), "{}", stderr(&o));
    }
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
    assert!(std::fs::symlink_metadata("/dev/full").unwrap().file_type().is_char_device());
}

#[test]
fn the_oedometer_runs_the_same_from_its_folder_and_from_its_packed_archive() {
    let dir = temp_dir("pkg_oedometer");
    let tar = dir.join("oedometer.tar");
    let o = bin().arg("pack").arg(oedometer()).arg("-o").arg(&tar).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let quick = ["--set", "quick=true", "--set", "samples=1", "--out"];
    let from_folder = bin().arg("run").arg(oedometer()).args(quick).arg(dir.join("folder")).output().unwrap();
    assert!(from_folder.status.success(), "{}", stderr(&from_folder));
    let from_archive = bin().arg("run").arg(&tar).args(quick).arg(dir.join("archive")).output().unwrap();
    assert!(from_archive.status.success(), "{}", stderr(&from_archive));
    let csv = |sub: &str| std::fs::read_to_string(dir.join(sub).join("stages_sample1.csv")).unwrap();
    assert_eq!(csv("folder").lines().count(), 9, "header, preload and 7 stages");
    assert_eq!(csv("folder"), csv("archive"), "same package, same results, bit for bit");
}

/// A package whose fluid is far too stiff for the pores of its bonded column (the scene of
/// engine/tests/pore_coupling.rs's stiff-fluid test, K_f = 1e13 Pa): `bulk_modulus` is
/// limited to `k_range`, and `dt_rate` (dt in standard steps) is offered when `with_dt_rate`.
fn stiff_fluid_package(dir: &Path, k_range: &str, with_dt_rate: bool) -> PathBuf {
    let pkg = dir.join("stiff");
    std::fs::create_dir_all(&pkg).unwrap();
    let dt_rate = if with_dt_rate {
        r#"(name: "dt_rate", type: float, default: 1.0, unit: "× standard dt", range: (0.01, 1.0), help: "dt"),"#
    } else {
        ""
    };
    std::fs::write(
        pkg.join("simulator.ron"),
        format!(
            r#"(name: "stiff", version: "0.1.0", description: "a stiff fluid in a bonded column", entry: "main.rhai",
                parameters: [
                    (name: "bulk_modulus", type: float, default: 1e13, unit: "Pa", range: {k_range}, help: "K_f"),
                    {dt_rate}
                ])"#
        ),
    )
    .unwrap();
    std::fs::write(
        pkg.join("main.rhai"),
        r#"let a = 1e-3;
           let d = new_model("column");
           let m = material_micro("grain", #{ kn: 1e6, ks: 4e5, mu_p: 0.5, r: 0.5 * a, density: 2650.0 });
           d.add_elements(make_lattice("sc", 3, 3, 4, a), m, "sample");
           d.fix("sample", "xy");
           d.add_group("bottom", d.z < 0.5 * a);
           d.fix("bottom", "xyz");
           d.connect("sample", 1e-3 * a);
           d.gravity = [0.0, 0.0, -9.81];
           d.damping = 0.3;
           d.set_standard_dt();
           d.dt = d.standard_dt() * (params.dt_rate ?? 1.0);
           d.fluid = #{ bulk_modulus: params.bulk_modulus, viscosity: 1e3, max_substeps: 1000 };
           d.enable("pore_flow");
           d.run(3000);
           print(`ran ${d.step} steps`);"#,
    )
    .unwrap();
    pkg
}

/// The number after `key` in `text`, up to the next space, comma or parenthesis.
fn number_after(text: &str, key: &str) -> f64 {
    let tail = text.split(key).nth(1).unwrap_or_else(|| panic!("no `{key}` in {text}"));
    let end = tail.find([' ', ',', ')', '\n']).unwrap_or(tail.len());
    tail[..end].trim_end_matches('.').parse().unwrap_or_else(|_| panic!("`{key}` is not followed by a number: {text}"))
}

// Issue 30: a guard's fix lies inside the manifest's ranges. The stiff-fluid guard names a
// bulk modulus under this package's range: the message says it lies outside and offers the
// other fix, dt, as the package's dt_rate within its range, and that value runs. Without a
// dt_rate no fix lies within, and the message says to change the scene or widen a range.
#[test]
fn a_stiff_fluids_fix_outside_the_manifests_range_is_named_so_with_one_that_lies_inside() {
    let dir = temp_dir("pkg_stiff_fluid");
    let pkg = stiff_fluid_package(&dir, "(1e11, 1e14)", true);
    let o = bin().arg("run").arg(&pkg).args(["--backend", "cpu", "--out"]).arg(dir.join("out")).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    let k_f = number_after(&err, "soften it below K_f = ");
    assert!(k_f < 1e11, "the scene must ask for a K_f under the range: {err}");
    assert!(err.contains(&format!("bulk_modulus below {k_f:.3e} Pa lies outside its range 1e11 … 1e14")), "{err}");
    let dt_rate = number_after(&err, "Within its ranges: --set dt_rate=");
    assert!((0.01..=1.0).contains(&dt_rate), "the offer lies within dt_rate's range: {err}");
    let o = bin()
        .arg("run")
        .arg(&pkg)
        .args(["--backend", "cpu", "--set", &format!("dt_rate={dt_rate}"), "--out"])
        .arg(dir.join("fixed"))
        .output()
        .unwrap();
    assert!(o.status.success(), "the offered dt_rate={dt_rate} must run: {}", stderr(&o));
    assert!(stdout(&o).contains("ran 3000 steps"), "{}", stdout(&o));

    let dir = temp_dir("pkg_stiff_fluid_no_dt");
    let pkg = stiff_fluid_package(&dir, "(1e11, 1e14)", false);
    let o = bin().arg("run").arg(&pkg).args(["--backend", "cpu", "--out"]).arg(dir.join("out")).output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("dt is not among its parameters"), "{err}");
    assert!(err.contains("None of these fixes lies within this simulator's parameters"), "{err}");
}
