//! What a careless or hostile user cannot do: switch a limit off or make one panic, run two
//! runs into one folder, resume into another folder than the interrupted run's, or — with
//! any manifest and any archive a property test makes up — write outside the output folder.

use crate::common::*;
use matdem_engine::backend::RunControl;
use matdem_rs::package::Package;
use matdem_rs::sandbox::Limits;
use matdem_rs::script_run::{default_out_dir, RunConfig};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use std::path::{Path, PathBuf};

#[test]
fn a_zero_limit_is_refused_and_a_tiny_one_stops_the_script_with_a_message_not_a_panic() {
    let dir = temp_dir("hard_limits");
    for opt in ["--max-operations", "--max-string-size", "--max-array-size", "--max-map-size"] {
        let o = run_script(&dir, "p.rhai", "print(1);", &[opt, "0"]);
        assert_eq!(o.status.code(), Some(2), "{opt} 0: {}", stderr(&o));
        assert!(stderr(&o).contains("0 would switch the limit off"), "{opt} 0: {}", stderr(&o));
    }
    for opt in ["--max-string-size", "--max-array-size", "--max-map-size"] {
        let o = run_script(&dir, "p.rhai", "print(1);", &[opt, "1"]);
        assert!(o.status.success(), "{opt} 1: {}", stderr(&o));
        assert_eq!(stdout(&o).trim(), "1");
        let o = run_script(&dir, "p.rhai", "let s = \"ab\"; let a = [1, 2]; let m = #{a: 1, b: 2};", &[opt, "1"]);
        assert_eq!(o.status.code(), Some(1), "{opt} 1 must stop the script: {}", stderr(&o));
        assert!(stderr(&o).contains(&opt[2..]), "{opt} 1: {}", stderr(&o));
    }
    let o = run_script(&dir, "p.rhai", "let n = 0; loop { n += 1; }", &["--max-operations", "1"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("too many operations"), "{}", stderr(&o));
}

#[test]
fn a_second_run_into_a_folder_in_use_is_refused_naming_the_holder() {
    let dir = temp_dir("hard_lock");
    let out = dir.join("out");
    let held = matdem_rs::out_lock::OutLock::acquire(&out, "the test's own run").unwrap();
    let o = run_script(&dir, "p.rhai", "print(1);", &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains(&format!("is in use by matdem-rs pid {} (the test's own run)", std::process::id())), "{e}");
    assert!(!out.join("run.ron").exists(), "the refused run wrote its record");
    drop(held);
    let o = run_script(&dir, "p.rhai", "print(1);", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    // A run into a folder an earlier run filled (its run.ron and index.html) says so.
    let o = run_script(&dir, "p.rhai", "print(1);", &[]);
    assert!(o.status.success() && stderr(&o).contains("already holds 2 file(s) or folder(s) from an earlier run"));
}

#[test]
fn resume_writes_where_the_interrupted_run_wrote_or_refuses() {
    let dir = temp_dir("hard_resume_out");
    std::fs::write(dir.join("p.rhai"), "print(1);").unwrap();
    let o = bin()
        .arg("run")
        .arg(dir.join("p.rhai"))
        .arg("--resume")
        .arg(dir.join("a"))
        .arg("--out")
        .arg(dir.join("b"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--resume continues the run in") && stderr(&o).contains("drop --out"));
    assert!(!dir.join("b").exists());
}

#[test]
fn the_default_output_folder_is_always_one_folder_inside_out() {
    for stem in ["oedometer", "..", ".", "a/b", "/etc", ""] {
        let d = default_out_dir(std::ffi::OsStr::new(stem));
        let parts: Vec<_> = d.components().collect();
        assert_eq!(parts.len(), 2, "{stem:?} gives {}", d.display());
        assert_eq!(parts[0].as_os_str(), "out");
        assert!(matches!(parts[1], std::path::Component::Normal(_)), "{stem:?} gives {}", d.display());
    }
}

/// A tar archive written header by header, so entries may say anything (the tar crate's
/// builder refuses `..` and absolute names).
fn raw_archive(entries: &[(String, Vec<u8>)]) -> Vec<u8> {
    let mut b = tar::Builder::new(Vec::new());
    for (name, bytes) in entries {
        let mut h = tar::Header::new_old();
        let n = name.len().min(99);
        h.as_old_mut().name[..n].copy_from_slice(&name.as_bytes()[..n]);
        h.set_size(bytes.len() as u64);
        h.set_mode(0o644);
        h.set_cksum();
        b.append(&h, bytes.as_slice()).unwrap();
    }
    b.into_inner().unwrap()
}

/// Every file under `dir`, relative to it.
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let p = e.path();
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(p);
            } else {
                out.push(p.strip_prefix(dir).unwrap().to_path_buf());
            }
        }
    }
    out
}

#[test]
fn no_generated_package_writes_outside_its_output_folder() {
    let victim = std::env::temp_dir().join(format!("matdem-prop-victim-{}", std::process::id()));
    let victim_text = victim.display().to_string();
    let words = prop::sample::select(vec![
        "sim", "..", ".", "", "/", "a/b", ".bashrc", "~", "run.ron", "resume", "x y", "é", "-rf", "out",
    ]);
    // Weighted so that about half the packages open and run.
    let name = prop_oneof![
        3 => "[a-z][a-z0-9._-]{0,8}",
        1 => prop::collection::vec(words.clone(), 1..4).prop_map(|w| w.concat()),
        1 => Just(victim_text.clone()),
        1 => "[a-zA-Z0-9._/-]{0,12}",
    ];
    let entry_dir = prop_oneof![
        6 => Just(""),
        1 => prop::sample::select(vec!["./", "../", "/", "a/", "a/../", "a/../../", "pkg/"]),
    ];
    let target = prop_oneof![
        prop::collection::vec(words, 1..4).prop_map(|w| w.join("/")),
        Just(format!("{victim_text}/x.csv")),
        Just("../../x.csv".to_string()),
    ];
    let case = (name.clone(), name, entry_dir.clone(), entry_dir, target, prop::bool::weighted(0.1));
    let root = temp_dir("hard_prop_packages");
    let n = std::cell::Cell::new(0);
    let refused = std::cell::Cell::new(0);
    TestRunner::new(Config { cases: 64, failure_persistence: None, ..Config::default() })
        .run(&case, |(name, version, manifest_dir, script_dir, target, twice)| {
            n.set(n.get() + 1);
            let dir = root.join(format!("case{}", n.get()));
            std::fs::create_dir_all(&dir).unwrap();
            let manifest = format!("(name: {name:?}, version: {version:?}, description: \"\", entry: \"m.rhai\")");
            let script = format!("let t = new_table(); t.add_row(#{{ a: 1.0 }}); t.save({target:?});");
            let mut entries = vec![
                (format!("{manifest_dir}simulator.ron"), manifest.into_bytes()),
                (format!("{script_dir}m.rhai"), script.into_bytes()),
            ];
            if twice {
                entries.push((format!("{script_dir}m.rhai"), b"print(1);".to_vec()));
            }
            let archive = dir.join("p.tar");
            std::fs::write(&archive, raw_archive(&entries)).unwrap();
            match Package::open(&archive) {
                Err(_) => refused.set(refused.get() + 1),
                Ok(package) => {
                    let out = dir.join(default_out_dir(std::ffi::OsStr::new(&package.manifest.name)));
                    let cfg = RunConfig {
                        script: archive.clone(),
                        out_dir: out.clone(),
                        params: Vec::new(),
                        progress: false,
                        plan_only: false,
                        backend: matdem_rs::run_backend::RunBackend::Cpu,
                        control: RunControl::default(),
                        resume: None,
                        package: Some(package),
                        limits: Limits::default(),
                    };
                    let _ = matdem_rs::script_run::run_script(&cfg);
                    prop_assert!(out.starts_with(dir.join("out")), "output folder {}", out.display());
                }
            }
            for f in files_under(&dir) {
                prop_assert!(f == Path::new("p.tar") || f.starts_with("out"), "{} was written", f.display());
            }
            prop_assert!(!victim.exists(), "{} was written", victim.display());
            Ok(())
        })
        .unwrap();
    let (n, refused) = (n.get(), refused.get());
    eprintln!("{n} generated packages: {refused} refused at opening, the rest wrote only inside out/");
    assert!(refused > 0 && refused < n, "the generator should make both kinds of package");
}

#[test]
fn sigterm_stops_a_script_loop_within_two_seconds_with_a_clear_record() {
    let script = "print(\"looping\"); let n = 0; loop { n += 1; }";
    let (code, secs, record) =
        terminate_after_first_line("hard_sigterm_loop", script, &["--max-operations", "1000000000000"]);
    assert_eq!(code, Some(130));
    assert!(secs < 2.0, "took {secs:.2} s");
    assert!(record.contains("status: \"stopped\"") && record.contains("exit_code: Some(130)"), "{record}");
}

#[test]
fn sigterm_stops_a_large_box_build_within_two_seconds() {
    // About 2·10⁶ grains: packing them takes far longer than the test waits.
    let script = r#"print("building");
        let b = new_box("big"); b.sample_w = 0.2; b.sample_l = 0.2; b.sample_h = 0.2; b.ball_r = 1.0e-3;
        b.build_initial_model();
        print("built");"#;
    let (code, secs, record) = terminate_after_first_line("hard_sigterm_build", script, &[]);
    assert_eq!(code, Some(130));
    assert!(secs < 2.0, "took {secs:.2} s");
    assert!(record.contains("status: \"stopped\""), "{record}");
}

#[test]
fn messages_name_the_real_cause() {
    let dir = temp_dir("hard_messages");
    let box_with = |line: &str| {
        format!("let b = new_box(\"t\"); b.sample_w = 0.003; b.sample_l = 0.003; b.sample_h = 0.002; {line}\nb.build_initial_model();")
    };
    let o = run_script(&dir, "g.rhai", &box_with("b.gradation = [[0.0 / 0.0, 1e-3, 1.0]];"), &[]);
    assert!(stderr(&o).contains("r_min") && !stderr(&o).contains("young"), "{}", stderr(&o));
    let o = run_script(&dir, "s.rhai", &box_with("b.seed = -1;"), &[]);
    assert!(stderr(&o).contains("seed must be 0 or more, got -1"), "{}", stderr(&o));
    let o = run_script(&dir, "r.rhai", "material_micro(\"m\", #{ kn: 1e6, ks: 4e5, r: 0.0 });", &[]);
    assert!(stderr(&o).contains("`r` = 0") && !stderr(&o).contains("young"), "{}", stderr(&o));
    let o = run_script(&dir, "l.rhai", "load_model(\"../x\");", &[]);
    assert!(stderr(&o).contains("`..` climbs out") && !stderr(&o).contains("output path"), "{}", stderr(&o));
    let o = run_script(&dir, "c.rhai", "print(params);", &["--set", "case=1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("parameter name `case` is a word Rhai reserves"), "{}", stderr(&o));
    let oedometer = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/oedometer");
    // A comma list (comma_list): another number, an empty item or one given twice is refused
    // before anything runs, with what to give.
    for (samples, said) in [
        ("4", "samples: `4` is not a choice; give a comma list of 1, 2, 3"),
        ("", "samples is empty; give a comma list of 1, 2, 3"),
        ("1,,3", "samples: an empty item in \"1,,3\"; give a comma list of 1, 2, 3"),
        ("1,3,1", "samples: `1` is given twice; give each at most once"),
    ] {
        let o = bin()
            .arg("run")
            .arg(&oedometer)
            .args(["--set", &format!("samples={samples}"), "--out"])
            .arg(dir.join("oed"))
            .output()
            .unwrap();
        assert!(stderr(&o).contains(said) && !stderr(&o).contains("deposition"), "{}", stderr(&o));
    }
    // A 400 kB generated line with an error at its end is shown around the error only.
    let o = run_script(&dir, "long.rhai", &format!("let a = [{}1 +];", "1, ".repeat(100_000)), &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).len() < 2_000, "{} bytes of report", stderr(&o).len());
}

#[test]
fn a_study_reference_outside_its_grid_is_refused_before_any_run() {
    let dir = temp_dir("hard_study_reference");
    std::fs::write(dir.join("s.rhai"), "report(\"m\", params.a * 1.0);").unwrap();
    let o = bin()
        .arg("study")
        .arg(dir.join("s.rhai"))
        .args(["--vary", "a=1,2", "--metric", "m", "--reference", "a=3", "--out"])
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert_ne!(o.status.code(), Some(0));
    assert!(stderr(&o).contains("--reference a=3 matches no setting of the --vary grid"), "{}", stderr(&o));
    assert!(!dir.join("out/run01").exists(), "a run started before the reference was checked");
}

#[test]
fn sigterm_stops_a_study_and_its_running_setting_saves_its_resume_point() {
    let dir = temp_dir("hard_sigterm_study");
    std::fs::write(
        dir.join("s.rhai"),
        r#"let b = new_box("t"); b.sample_w = 0.003; b.sample_l = 0.003; b.sample_h = 0.002; b.ball_r = 0.4e-3;
        let d = b.build_initial_model();
        d.set_group_mat("sample", material_micro("m", #{ kn: 2e5, ks: 8e4, mu_p: 0.3, r: 0.4e-3 }));
        d.set_standard_dt();
        d.balance(1000000000);
        report("m", 1.0);"#,
    )
    .unwrap();
    let out = dir.join("out");
    let mut study = bin()
        .arg("study")
        .arg(dir.join("s.rhai"))
        .args(["--vary", "a=1,2", "--metric", "m", "--backend", "cpu", "--out"])
        .arg(&out)
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while !out.join("run01/run.ron").exists() {
        assert!(started.elapsed().as_secs() < 30, "the first setting never started");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(500));
    let sent = std::time::Instant::now();
    assert!(std::process::Command::new("kill").arg("-TERM").arg(study.id().to_string()).status().unwrap().success());
    let code = loop {
        if let Some(status) = study.try_wait().unwrap() {
            break status.code();
        }
        assert!(sent.elapsed().as_secs() < 20, "the study still runs 20 s after SIGTERM");
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let secs = sent.elapsed().as_secs_f64();
    assert_eq!(code, Some(130));
    assert!(secs < 2.0, "took {secs:.2} s");
    let record = std::fs::read_to_string(out.join("run01/run.ron")).unwrap();
    assert!(record.contains("status: \"interrupted\""), "{record}");
    assert!(out.join("run01/resume/journal.ron").is_file());
    // A study is a sweep: every setting's folder is planned up front, and stays unrun.
    assert!(!out.join("run02/run.ron").exists(), "the study went on to the next setting");
}
