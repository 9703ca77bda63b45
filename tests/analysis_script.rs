//! The analysis API from scripts (issue 31): the contact table and its CSV, the contact-force
//! lanes, fabric, rose, measurement regions with strain against a kept state, force chain
//! pictures, and the one-way ANOVA; bad input refused by name.

use crate::common::{run_script, stderr, stdout, temp_dir, SMALL_BOX};

// A small box settled under gravity: d.contacts() has rows with walls named, saves to CSV
// with its header in order, and selecting a group keeps the rows that touch it; the table's
// forces summed per element (here: over the whole model, walls' share apart) equal the
// contact lanes; fabric, rose, measure and force chains run and write their files.
#[test]
fn contact_table_fabric_measure_and_pictures_from_a_script() {
    let dir = temp_dir("analysis_script");
    let script = format!(
        r#"{SMALL_BOX}
d.gravity = [0.0, 0.0, -20000.0];
d.local_damping = 0.5;
d.run(12000);
let t = d.contacts();
t.save("contacts.csv");
let walls = t["wall"].filter(|w| w != "").len();
let pairs = t["j"].is_finite().count();
let sub = d.contacts(d.z < 0.001);
// Σ over the rows of the force on i and, for pairs, its opposite on j, is Σ of the lanes.
let pair_f = t["fz"].select(t["j"].is_finite());
let lane = d.contact_fz.sum();
let wall_f = t["fz"].select(!t["j"].is_finite()).sum();
let f = d.fabric();
let inner = #{{ lo: [0.0, 0.0, 0.0], hi: [0.004, 0.004, 0.0015] }};
let kept = #{{ x: d.x, y: d.y, z: d.z }};
let m = d.measure(inner);
let still = d.measure(inner, kept);
d.rose("rose");
d.rose("rose_force", #{{ weighted: true, bins: 24, plane: "xz" }});
d.show_force_chains("chains", #{{ slice: 0.002, threshold: 0.5 }});
print(`result ${{t.rows}} ${{walls}} ${{pairs}} ${{sub.rows}} ${{lane}} ${{wall_f}} ${{f.coordination}} ${{f.values[0] + f.values[1] + f.values[2]}} ${{m.stress_zz}} ${{m.porosity}} ${{still.volumetric_strain}} ${{m.elements}}`);
"#
    );
    let o = run_script(&dir, "analysis.rhai", &script, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let line = out.lines().find(|l| l.starts_with("result ")).unwrap_or_else(|| panic!("no result in {out}"));
    let v: Vec<f64> = line.split_whitespace().skip(1).map(|w| w.parse().unwrap()).collect();
    eprintln!("{line}");
    let (rows, walls, pairs, sub) = (v[0], v[1], v[2], v[3]);
    assert!(walls > 0.0 && pairs > 0.0 && rows == walls + pairs, "{line}");
    assert!(sub > 0.0 && sub < rows);
    // The pairs cancel in the lanes' total: what is left is the walls' share.
    assert!((v[4] - v[5]).abs() <= 1e-9 * v[5].abs().max(1e-12), "Σ lane {} vs walls' share {}", v[4], v[5]);
    assert!(v[6] > 0.0 && (v[7] - 1.0).abs() < 1e-12, "fabric trace 1");
    assert!(v[8] > 0.0 && v[9] > 0.2 && v[9] < 0.9, "stress and porosity of the bottom layer");
    assert!(v[10].abs() < 1e-12, "no motion since the state was kept: no strain ({})", v[10]);
    let csv = std::fs::read_to_string(dir.join("out/contacts.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    assert_eq!(header, "i,j,wall,x,y,z,nx,ny,nz,overlap,fn,fs_x,fs_y,fs_z,fs,fx,fy,fz,bonded,bond");
    assert!(csv.contains(",bottom,"), "a wall contact names its wall");
    assert_eq!(csv.lines().count() as f64, rows + 1.0);
    for f in ["rose.svg", "rose.png", "rose_force.svg", "chains.svg", "chains.png"] {
        assert!(dir.join("out").join(f).exists(), "{f} written");
    }
}

// NIST StRD SiRstv from a script: the certified F (1.18046237440255) and sums of squares.
#[test]
fn anova_oneway_from_a_script_gives_nist_sirstv() {
    let e = matdem_rs::new_engine(std::rc::Rc::new(matdem_rs::api::Host::new(temp_dir("anova_oneway"))));
    let ok: bool = e
        .eval(
            "let a = anova_oneway([\
               field([196.3052, 196.1240, 196.1890, 196.2569, 196.3403]),\
               field([196.3042, 196.3825, 196.1669, 196.3257, 196.0422]),\
               [196.1303, 196.2005, 196.2889, 196.0343, 196.1811],\
               field([196.2795, 196.1748, 196.1494, 196.1485, 195.9885]),\
               field([196.2119, 196.1051, 196.1850, 196.0052, 196.2090])]);\
             (a.f / 1.18046237440255 - 1.0).abs() < 1e-8 && (a.ss_between / 5.11462616e-2 - 1.0).abs() < 1e-8 \
               && (a.ss_within / 2.1663656e-1 - 1.0).abs() < 1e-8 && a.dof_between == 4 && a.dof_within == 20 \
               && a.p > 0.3 && a.p < 0.4",
        )
        .unwrap();
    assert!(ok);
}

#[test]
fn bad_analysis_input_is_refused_by_name() {
    let dir = temp_dir("analysis_refusals");
    for (tail, words) in [
        ("d.measure(#{ lo: [0.0, 0.0, 0.0] });", &["region needs `hi`"][..]),
        ("d.measure(#{ centre: [0.0, 0.0, 0.0], radius: 1.0 });", &["unknown region key `centre`"]),
        ("d.measure(#{ center: [0.0, 0.0, 0.0], radius: -1.0 });", &["radius must be > 0"]),
        ("d.measure(#{ lo: [0.0, 0.0, 0.0], hi: [1.0, -1.0, 1.0] });", &["inverted along y"]),
        ("d.measure(#{ center: [9.0, 9.0, 9.0], radius: 1e-4 });", &["no element has its centre in the region"]),
        ("d.measure(#{ center: [0.002, 0.002, 0.001], radius: 0.01 }, #{ x: d.x });", &["needs `y`"]),
        ("d.rose(\"r\", #{ bins: 2 });", &["bins = 2"]),
        ("d.rose(\"r\", #{ plane: \"xx\" });", &["plane \"xx\""]),
        ("d.show_force_chains(\"c\", #{ slice: -1.0 });", &["slice half-width must be > 0"]),
        ("d.show_force_chains(\"c\", #{ width: 1.0 });", &["unknown option `width`"]),
        ("anova_oneway([field([1.0, 2.0])]);", &["two or more groups"]),
        ("anova_oneway([[1.0], [2.0]]);", &["single value"]),
        ("d.tx;", &["rotation is off"]),
    ] {
        let o = run_script(&dir, "bad.rhai", &format!("{SMALL_BOX}\n{tail}"), &[]);
        let e = stderr(&o);
        assert!(!o.status.success(), "`{tail}` should fail");
        for w in words {
            assert!(e.contains(w), "`{tail}`: {e:?} lacks {w:?}");
        }
    }
}
