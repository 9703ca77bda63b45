//! `--backend auto` with a GPU to measure: the first run times its scene on both backends,
//! says both figures and the choice, and the whole run steps on the faster; a resumed run
//! continues where the interrupted one stepped. CI has only Mesa's lavapipe, which `auto`
//! measures only with MATDEM_AUTO_SOFTWARE=1 (and which the CPU beats on these scenes).

use crate::common::{bin, gpu_required, stderr, stdout, temp_dir};
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// Two models, the first made before any run: a grain box dropped under gravity, and a
/// second box balanced after it.
const SCRIPT: &str = r#"
let b = new_box("drop");
b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3;
let d = b.build_initial_model();
d.gravity = [0.0, 0.0, -9.81];
d.set_standard_dt();
let c = new_box("second");
c.sample_w = 0.003; c.sample_l = 0.003; c.sample_h = 0.003; c.ball_r = 0.5e-3; c.seed = 3;
let e = c.build_initial_model();
e.gravity = [0.0, 0.0, -9.81];
e.set_standard_dt();
d.balance(300);
e.balance(200);
print(`zmean=${d.z.mean()} ${e.z.mean()}`);
"#;

fn auto(software: bool) -> Command {
    let mut c = bin();
    if software {
        c.env("MATDEM_AUTO_SOFTWARE", "1");
    } else {
        c.env_remove("MATDEM_AUTO_SOFTWARE");
    }
    c
}

fn run(c: &mut Command, script: &Path, out: &Path, backend: &str) -> Output {
    c.arg("run").arg(script).arg("--out").arg(out).args(["--backend", backend]).output().unwrap()
}

/// Whether this machine has only a software adapter (or none): what the tests below expect.
fn no_hardware_gpu(o: &Output) -> bool {
    let err = stderr(o);
    !(err.contains("(Vulkan, hardware)") || err.contains(", hardware)"))
}

#[test]
fn auto_measures_the_cpu_and_the_gpu_at_the_first_run_and_steps_like_a_cpu_run() {
    let dir = temp_dir("auto_measures");
    let script = dir.join("s.rhai");
    std::fs::write(&script, SCRIPT).unwrap();
    let o = run(&mut auto(true), &script, &dir.join("auto"), "auto");
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    if err.contains("no GPU adapter") && !gpu_required() {
        eprintln!("skipped: no GPU adapter: {err}");
        return;
    }
    if !no_hardware_gpu(&o) {
        eprintln!("skipped: a hardware GPU chooses by the scene: {err}");
        return;
    }
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("auto: ")).collect();
    assert_eq!(lines.len(), 1, "one decision for the run, at its first run: {err}");
    let line = lines[0];
    assert!(
        line.starts_with("auto: cpu ") && line.contains("particle-steps/s, gpu (") && line.ends_with("→ cpu"),
        "{line}"
    );
    let record = std::fs::read_to_string(dir.join("auto/run.ron")).unwrap();
    assert!(record.contains("backend: \"cpu (f64)\"") && record.contains("speed_test: Some(\"auto: cpu"), "{record}");

    let cpu = run(&mut bin(), &script, &dir.join("cpu"), "cpu");
    assert!(cpu.status.success(), "{}", stderr(&cpu));
    assert_eq!(stdout(&o), stdout(&cpu), "both models step on the CPU, bit for bit");
}

#[test]
fn auto_passes_over_a_software_gpu_without_measuring_unless_asked() {
    let dir = temp_dir("auto_software");
    let script = dir.join("s.rhai");
    std::fs::write(&script, SCRIPT).unwrap();
    let o = run(&mut auto(false), &script, &dir.join("out"), "auto");
    assert!(o.status.success(), "{}", stderr(&o));
    if !no_hardware_gpu(&o) {
        eprintln!("skipped: a hardware GPU is measured: {}", stderr(&o));
        return;
    }
    assert!(stderr(&o).contains("backend: cpu (f64"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("particle-steps/s"), "no speed test: {}", stderr(&o));
}

#[test]
fn a_resumed_auto_run_continues_on_the_cpu_or_gpu_the_interrupted_run_chose() {
    use std::io::BufRead;
    let dir = temp_dir("auto_resume");
    let script = dir.join("s.rhai");
    // A decision at the first balance, a line on stdout, then a long run to interrupt.
    std::fs::write(&script, format!("{SCRIPT}\nfor k in 0..1000 {{ d.run(2000); }}\nprint(\"done\");")).unwrap();
    let out = dir.join("out");
    let mut child = auto(true)
        .arg("run")
        .arg(&script)
        .arg("--out")
        .arg(&out)
        .args(["--backend", "auto"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut first = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap()).read_line(&mut first).unwrap();
    let term = Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap();
    assert!(term.success());
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    if err.contains("no GPU adapter") && !gpu_required() {
        eprintln!("skipped: no GPU adapter: {err}");
        return;
    }
    if !no_hardware_gpu(&o) {
        eprintln!("skipped: a hardware GPU chooses by the scene: {err}");
        return;
    }
    assert_eq!(o.status.code(), Some(130), "interrupted in its long run: {err}");
    assert!(err.contains("→ cpu"), "{err}");
    let journal = std::fs::read_to_string(out.join("resume/journal.ron")).unwrap();
    assert!(journal.contains("backend: \"cpu (f64)\""), "the journal names the chosen backend");

    // On the GPU it would change precision half-way: refused, with the backend to give.
    let gpu = bin().arg("run").arg(&script).arg("--resume").arg(&out).args(["--backend", "gpu"]).output().unwrap();
    assert_eq!(gpu.status.code(), Some(2), "{}", stderr(&gpu));
    assert!(
        stderr(&gpu).contains("stepped on cpu, this one would on gpu: resume with --backend cpu"),
        "{}",
        stderr(&gpu)
    );

    // `auto` continues on the CPU without measuring again; cut short by a second signal.
    let child = auto(true)
        .arg("run")
        .arg(&script)
        .arg("--resume")
        .arg(&out)
        .args(["--backend", "auto"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap().success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(!stderr(&o).contains("particle-steps/s"), "no second speed test: {}", stderr(&o));
    let record = std::fs::read_to_string(out.join("run.ron")).unwrap();
    assert!(record.contains("backend: \"cpu (f64)\"") && record.contains("resumed_from: Some("), "{record}");
}
