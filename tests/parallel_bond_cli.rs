//! Parallel bonds from a script, through the CLI: a bonded box of grains whose bonds are made
//! parallel bonds (`d.bond_parallel`), settled under gravity on the CPU and on the GPU (Mesa's
//! software Vulkan in CI); the script reads back how many bonds it made and how many hold, the
//! plan's stage and the bonds' energy. Bad parameters are refused naming the key.

use crate::common::{gpu_required, run_script, stderr, stdout, temp_dir};

const SCRIPT: &str = r#"
let b = new_box("pb");
b.sample_w = 0.004; b.sample_l = 0.004; b.sample_h = 0.004; b.ball_r = 0.5e-3; b.seed = 3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("m", #{ kn: 2e5, ks: 8e4, mu_p: 0.3, r: 0.5e-3 }));
d.gravity = [0.0, 0.0, -9.81];
let made = d.connect("sample", 1e-4);
let refused = "";
try { d.bond_parallel(#{ lambda: 1.0, e_star: 1e8, k_ratio: 2.6, sigma_c: 1e6, c: 1e6, psi: 30.0 }); }
catch (e) { refused = `${e}`; }
let pb = d.bond_parallel(#{ lambda: 1.0, e_star: 1e8, k_ratio: 2.6, sigma_c: 1e6, c: 1e6, phi: 30.0 });
d.set_standard_dt();
d.run(500);
let e = d.energies();
print(`made=${made}`);
print(`parallel=${pb}`);
print(`intact=${d.parallel_bonds}`);
print(`matdem_bonds=${d.bonds}`);
print(`refused=${refused}`);
print(d.plan());
"#;

fn value(out: &str, key: &str) -> i64 {
    out.lines()
        .find_map(|l| l.strip_prefix(&format!("{key}=")))
        .unwrap_or_else(|| panic!("no {key} in {out}"))
        .trim()
        .parse()
        .unwrap()
}

// Every MatDEM bond becomes a parallel bond (and no MatDEM bond is left); strong bonds under the
// grains' weight all hold over 500 steps; the plan runs the parallel_bond stage with rotation;
// the CPU and GPU runs agree on the counts. A misspelt key is refused with the keys it takes.
#[test]
fn a_script_makes_parallel_bonds_and_reads_them_back_on_the_cpu_and_the_gpu() {
    for backend in ["cpu", "gpu"] {
        let dir = temp_dir(&format!("parallel_bond_{backend}"));
        let o = run_script(&dir, "s.rhai", SCRIPT, &["--backend", backend]);
        if backend == "gpu" && o.status.code() == Some(2) && !gpu_required() {
            eprintln!("skipped: no GPU adapter: {}", stderr(&o));
            return;
        }
        assert!(o.status.success(), "{backend}: {}", stderr(&o));
        let out = stdout(&o);
        let made = value(&out, "made");
        assert!(made > 10, "{out}");
        assert_eq!(value(&out, "parallel"), made, "{out}");
        assert_eq!(value(&out, "intact"), made, "{out}");
        assert_eq!(value(&out, "matdem_bonds"), 0, "{out}");
        assert!(out.contains("parallel_bond") && out.contains("parallel bonds(") && out.contains("rotation"), "{out}");
        let refused = out.lines().find(|l| l.starts_with("refused=")).unwrap();
        assert!(refused.contains("psi") && refused.contains("phi"), "{refused}");
    }
}
