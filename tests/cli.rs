//! The command line end to end: `run` on the oedometer package in quick mode, `plan`,
//! `--set` parameters and `--help`.

use crate::common::*;

fn csv_column(text: &str, name: &str) -> Vec<f64> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let k = header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no column {name} in {header:?}"));
    lines.map(|l| l.split(',').nth(k).unwrap().parse().unwrap()).collect()
}

#[test]
fn oedometer_package_quick_writes_outputs_and_strain_and_coordination_grow() {
    let dir = temp_dir("compress_quick");
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/oedometer");
    let o = bin().args(["run", example, "--set", "quick=true", "--out"]).arg(&dir).output().unwrap();
    assert!(o.status.success(), "stderr:\n{}\nstdout:\n{}", stderr(&o), stdout(&o));
    for f in [
        "stages_sample1.csv",
        "stages_sample2.csv",
        "stages_sample3.csv",
        "stages_all.csv",
        "stress_strain.svg",
        "stress_strain.png",
        "coordination.svg",
        "coordination.png",
        "void_ratio_change.png",
        "class_displacement_sample1.png",
        "class_force_sample3.svg",
        "sample1_size_class.png",
        "sample2_contact_load.svg",
        "sample1_chains_50kPa.png",
        "sample3_chains_3200kPa.svg",
        "sample2_rose_50kPa.svg",
        "sample3_rose_3200kPa.png",
    ] {
        assert!(dir.join(f).is_file(), "missing {f}");
    }
    for k in 1..=3 {
        let csv = std::fs::read_to_string(dir.join(format!("stages_sample{k}.csv"))).unwrap();
        let strain = csv_column(&csv, "strain");
        let nc = csv_column(&csv, "coordination");
        assert_eq!(strain.len(), 8, "preload + 7 stages");
        assert!(strain.windows(2).all(|w| w[1] > w[0]), "sample {k}: strain grows with every stage: {strain:?}");
        assert!(nc.last() > nc.first(), "sample {k}: coordination grows: {nc:?}");
    }
    assert!(stdout(&o).contains("strain at 3.2 MPa"));
}

#[test]
fn plan_prints_what_is_simulated_and_what_is_not() {
    let dir = temp_dir("plan");
    std::fs::write(
        dir.join("p.rhai"),
        r#"let b = new_box("p"); b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
           let d = b.build_initial_model(); d.contact_law = "hertz"; d.set_standard_dt(); d.gravity = [0.0, 0.0, -9.81];
           d.balance(100); print("not reached");"#,
    )
    .unwrap();
    let o = bin().arg("plan").arg(dir.join("p.rhai")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("step plan:") && out.contains("hertz") && out.contains("gravity"), "{out}");
    assert!(out.contains("not simulated:") && out.contains("rotation") && out.contains("heat"), "{out}");
    assert!(!out.contains("not reached"));
}

/// `plan` ends the script at its first run with a value only the host can make: `try`/`catch`
/// cannot hold it back, and a script throwing the old marker string is a plain error.
#[test]
fn plan_stop_cannot_be_caught_or_forged_by_a_script() {
    let dir = temp_dir("plan_stop");
    std::fs::write(
        dir.join("caught.rhai"),
        r#"let b = new_box("p"); b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
           let d = b.build_initial_model(); d.set_standard_dt();
           try { d.run(10); } catch (e) { print("caught"); }
           print("after the plan");"#,
    )
    .unwrap();
    let o = bin().arg("plan").arg(dir.join("caught.rhai")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("step plan:"), "{out}");
    assert!(!out.contains("caught") && !out.contains("after the plan"), "{out}");

    std::fs::write(dir.join("forged.rhai"), r#"throw "__matdem_plan_done__";"#).unwrap();
    let o = bin().arg("plan").arg(dir.join("forged.rhai")).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "a thrown string is a script error: {}", stderr(&o));
}

#[test]
fn set_values_reach_the_script_as_params() {
    let dir = temp_dir("params");
    let o = run_script(
        &dir,
        "s.rhai",
        "print(`${params.n + 1} ${params.name} ${params.flag}`);",
        &["--set", "n=41", "--set", "name=oed", "--set", "flag=true"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), "42 oed true");
}

#[test]
fn help_shows_examples() {
    let o = bin().arg("--help").output().unwrap();
    assert!(stdout(&o).contains("matdem-rs run examples/oedometer"));
}

#[test]
fn gpu_backend_without_adapter_is_a_clear_error() {
    let dir = temp_dir("gpu");
    std::fs::write(dir.join("s.rhai"), "print(1);").unwrap();
    let o = bin_without_gpu().arg("run").arg(dir.join("s.rhai")).args(["--backend", "gpu"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("error: no usable GPU") && err.contains("--backend cpu"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn auto_backend_without_a_hardware_gpu_runs_on_the_cpu_and_says_why() {
    let dir = temp_dir("auto");
    std::fs::write(dir.join("s.rhai"), "print(1);").unwrap();
    let o = bin_without_gpu().arg("run").arg(dir.join("s.rhai")).args(["--backend", "auto"]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("backend: cpu (f64"), "{}", stderr(&o));
}

// The backend line says the threads the CPU passes run on: rayon's pool, which
// RAYON_NUM_THREADS sets (a sweep's point, a Slurm task), not the machine's cores.
#[test]
fn the_backend_line_says_the_threads_the_cpu_runs_on() {
    for (threads, said) in [("1", "backend: cpu (f64, 1 thread)"), ("3", "backend: cpu (f64, 3 threads)")] {
        let o = bin()
            .args(["bench", "--backend", "cpu", "--particles", "300", "--steps", "2", "--warmup", "1", "--json"])
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stderr(&o).contains(said), "RAYON_NUM_THREADS={threads}: {}", stderr(&o));
        let json = String::from_utf8_lossy(&o.stdout);
        assert!(json.contains(&format!("\"threads\":{threads},")), "{json}");
    }
}

// A script on the GPU (Mesa's software Vulkan in CI): a small box of grains balanced under
// gravity settles to the mean height the CPU finds, within 1e-3 relative.
#[test]
fn run_on_gpu_backend_matches_cpu() {
    let script = r#"
        let b = new_box("drop");
        b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
        let d = b.build_initial_model();
        d.gravity = [0.0, 0.0, -9.81];
        d.set_standard_dt();
        d.balance("standard");
        print(`zmean=${d.z.mean()}`);
    "#;
    let mut out = Vec::new();
    for backend in ["cpu", "gpu"] {
        let dir = temp_dir(&format!("gpu_run_{backend}"));
        let o = run_script(&dir, "s.rhai", script, &["--backend", backend]);
        if backend == "gpu" && o.status.code() == Some(2) && !gpu_required() {
            eprintln!("skipped: no GPU adapter: {}", stderr(&o));
            return;
        }
        assert!(o.status.success(), "{backend}: {}", stderr(&o));
        if backend == "gpu" {
            assert!(stderr(&o).contains("backend: gpu (f32) on"), "{}", stderr(&o));
        }
        let z: f64 = stdout(&o).lines().find_map(|l| l.strip_prefix("zmean=")).unwrap().trim().parse().unwrap();
        out.push(z);
    }
    assert!(((out[1] - out[0]) / out[0]).abs() < 1e-3, "mean height cpu {} gpu {}", out[0], out[1]);
}

// A script's energy account on the GPU: grains thrown at the floor of a small box (4000
// steps) release friction heat; `d.energies()` and the `heat` column of `d.record()` show the
// GPU's heat, equal to the CPU's within 1e-2, and the GPU's total within 1e-3 of its start.
#[test]
fn energies_and_record_show_the_heat_of_a_gpu_run() {
    let script = r#"
        let b = new_box("throw");
        b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
        let d = b.build_initial_model();
        d.gravity = [0.0, 0.0, -9.81];
        d.set_standard_dt();
        d.set_velocity("sample", [0.0, 0.0, -0.3]);
        let e0 = d.energies();
        d.run(4000);
        let e = d.energies();
        d.record();
        print(`heat=${e.heat_damping + e.heat_contact_damping + e.heat_friction + e.heat_breakage}`);
        print(`recorded=${d.status.last("heat")}`);
        print(`total0=${e0.total}`);
        print(`total=${e.total}`);
    "#;
    let mut heat = Vec::new();
    for backend in ["cpu", "gpu"] {
        let dir = temp_dir(&format!("gpu_heat_{backend}"));
        let o = run_script(&dir, "s.rhai", script, &["--backend", backend]);
        if backend == "gpu" && o.status.code() == Some(2) && !gpu_required() {
            eprintln!("skipped: no GPU adapter: {}", stderr(&o));
            return;
        }
        assert!(o.status.success(), "{backend}: {}", stderr(&o));
        let out = stdout(&o);
        let value = |key: &str| -> f64 {
            let line = out.lines().find_map(|l| l.strip_prefix(key)).unwrap_or_else(|| panic!("no {key} in {out}"));
            line.trim().parse().unwrap()
        };
        let (h, recorded, total0, total) = (value("heat="), value("recorded="), value("total0="), value("total="));
        eprintln!("{backend}: heat {h:e}, recorded {recorded:e}, total {total0:e} -> {total:e}");
        assert!(h > 0.0, "{backend}: the throw must release heat");
        assert_eq!(recorded, h, "{backend}: record's heat column");
        assert!((total - total0).abs() < 1e-3 * total0, "{backend}: the account moved from {total0:e} to {total:e}");
        heat.push(h);
    }
    assert!(((heat[1] - heat[0]) / heat[0]).abs() < 1e-2, "heat cpu {:e} gpu {:e}", heat[0], heat[1]);
}

// The paper's full ring (~290,000 elements a sample) would take hours on 2 cores: the run says
// so with its estimate before depositing anything, and what to use instead.
#[test]
fn oedometer_full_ring_says_before_depositing_that_it_takes_hours_and_what_to_use_instead() {
    let dir = temp_dir("compress_full_estimate");
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/oedometer");
    let o = bin()
        .args(["run", example, "--backend", "cpu", "--set", "full=true", "--set", "samples=1", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("No.1 would take about") && err.contains(" h on 2 CPU cores"), "{err}");
    assert!(err.contains("--backend gpu --set allow_hours=true") && err.contains("--set ring_mm=7"), "{err}");
    assert!(!dir.join("stages_sample1.csv").exists(), "nothing was deposited or loaded");
}

// The paper's CPT chamber at the paper's cone speed (~149,000 grains over the five groups,
// ~420,000 steps each) would take hours on 2 cores: the run says so with its estimate before
// packing any chamber (the estimate counts the grains from the chambers' volumes), and what to
// use instead, every suggestion within the manifest's ranges.
#[test]
fn cpt_full_chamber_at_the_papers_speed_says_before_packing_that_it_takes_hours_and_what_to_use_instead() {
    let dir = temp_dir("cpt_full_estimate");
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/cpt");
    let started = std::time::Instant::now();
    let o = bin()
        .args(["run", example, "--backend", "cpu", "--set", "full=true", "--set", "speed=0.02", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    let (out, err) = (stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(started.elapsed().as_secs_f64() < 20.0, "the estimate comes before any packing");
    assert!(out.contains("estimate: ") && out.contains(" grains over 5 group(s)") && out.contains(" MB)"), "{out}");
    assert!(out.contains("min (assuming 1e8 grain-steps/s there"), "the GPU rate is named as an assumption: {out}");
    assert!(!out.contains("packed in"), "nothing was packed: {out}");
    assert!(err.contains("this CPT run would take about") && err.contains(" h on 2 CPU cores"), "{err}");
    assert!(err.contains("--backend gpu --set allow_hours=true") && err.contains("--set scale=0.6"), "{err}");
    assert!(err.contains("--set speed=0.2"), "{err}");
    assert!(!dir.join("runs.csv").exists());
}

// The hot and cold injection's finest slab (ball_r 0.008 m, ~5,400 elements, its sweep cut
// by the step cap) would take hours on 2 cores: the run says so before depositing, with the
// estimate, where the step cap ends the sweep, and what to use instead.
#[test]
fn hot_cold_injection_finest_slab_says_before_depositing_that_it_takes_hours_and_what_to_use_instead() {
    let dir = temp_dir("hot_cold_fine_estimate");
    let example = concat!(env!("CARGO_MANIFEST_DIR"), "/examples/hot_cold_injection");
    let started = std::time::Instant::now();
    let o =
        bin().args(["run", example, "--backend", "cpu", "--set", "ball_r=0.008", "--out"]).arg(&dir).output().unwrap();
    let (out, err) = (stdout(&o), stderr(&o));
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(started.elapsed().as_secs_f64() < 20.0, "the estimate comes before deposition");
    assert!(out.contains("estimate: ~") && out.contains(" elements, ~") && out.contains(" MB)"), "{out}");
    assert!(out.contains("min (assuming 20 µs a sub-step there)"), "the GPU rate is named as an assumption: {out}");
    assert!(out.contains("max_steps = 400000 would end the sweep near"), "{out}");
    assert!(!out.contains("built:"), "nothing was deposited: {out}");
    assert!(err.contains("would take about") && err.contains(" h on 2 CPU cores"), "{err}");
    assert!(err.contains("--backend gpu --set allow_hours=true") && err.contains("--set ball_r=0.02"), "{err}");
    assert!(!dir.join("history.csv").exists());
}
