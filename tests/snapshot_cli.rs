//! ParaView snapshots: `d.snapshot` and `d.snapshot_every` write well-formed VTK XML whose
//! counts match the model (points, bonds as lines, components per array), and a `.pvd` that
//! lists the series in time order. Each file is parsed back.

use crate::common::{bin, stderr, stdout, temp_dir};
use roxmltree::{Document, Node};
use std::path::Path;

const SCRIPT: &str = r#"
let b = new_box("tiny");
b.ball_r = 0.5e-3; b.distri_rate = 0.2;
b.sample_w = 4e-3; b.sample_l = 4e-3; b.sample_h = 5e-3;
let d = b.build_initial_model();
d.set_group_mat("sample", material_micro("grain", #{ kn: 2e4, ks: 8e3, xb: 1e-4, fs0: 1.0, r: 0.5e-3, mu_p: 0.5 }));
d.set_standard_dt();
d.gravity = [0.0, 0.0, -500.0];
d.local_damping = 0.3;
d.run(3000);
d.snapshot_every(500);
d.run(200);
d.connect("all", 2e-5);
d.run(1800);
d.snapshot("final");
print(`${d.n} ${d.bonds}`);
"#;

/// The whitespace-separated values of a DataArray.
fn values(a: Node) -> Vec<f64> {
    a.text().unwrap_or("").split_whitespace().map(|v| v.parse::<f64>().unwrap()).collect()
}

fn find<'a>(n: Node<'a, 'a>, tag: &str) -> Node<'a, 'a> {
    n.descendants().find(|x| x.has_tag_name(tag)).unwrap_or_else(|| panic!("no <{tag}>"))
}

/// Parses a .vtp and checks its counts; returns (points, lines).
fn check_vtp(path: &Path, n: usize) -> (usize, usize) {
    let text = std::fs::read_to_string(path).unwrap();
    let doc = Document::parse(&text).unwrap_or_else(|e| panic!("{}: not well-formed XML: {e}", path.display()));
    let root = doc.root_element();
    assert_eq!(root.attribute("type"), Some("PolyData"));
    let piece = find(root, "Piece");
    let points: usize = piece.attribute("NumberOfPoints").unwrap().parse().unwrap();
    let lines: usize = piece.attribute("NumberOfLines").unwrap().parse().unwrap();
    assert_eq!(points, n, "{}", path.display());
    let point_data = find(piece, "PointData");
    let mut names = Vec::new();
    for a in point_data.children().filter(|c| c.has_tag_name("DataArray")) {
        let comps: usize = a.attribute("NumberOfComponents").unwrap().parse().unwrap();
        assert_eq!(values(a).len(), n * comps, "array {:?}", a.attribute("Name"));
        names.push(a.attribute("Name").unwrap().to_string());
    }
    assert_eq!(names, ["radius", "velocity", "displacement", "force", "group", "material"]);
    let radius = values(point_data.children().find(|c| c.attribute("Name") == Some("radius")).unwrap());
    assert!(radius.iter().all(|r| (0.4e-3..=0.6e-3).contains(r)), "radii as built");
    assert_eq!(values(find(find(piece, "Points"), "DataArray")).len(), 3 * n);
    let line_arrays: Vec<Node> = find(piece, "Lines").children().filter(|c| c.has_tag_name("DataArray")).collect();
    let connectivity = values(line_arrays[0]);
    let offsets = values(line_arrays[1]);
    assert_eq!(connectivity.len(), 2 * lines);
    assert!(connectivity.iter().all(|&i| i >= 0.0 && (i as usize) < n), "bond ends are particle ids");
    assert_eq!(offsets.last().copied().unwrap_or(0.0) as usize, 2 * lines);
    (points, lines)
}

#[test]
fn snapshots_are_well_formed_vtk_with_the_models_counts_and_a_time_ordered_collection() {
    let dir = temp_dir("snapshots");
    let script = dir.join("snap.rhai");
    std::fs::write(&script, SCRIPT).unwrap();
    let o = bin().arg("run").arg(&script).arg("--out").arg(dir.join("out")).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let printed: Vec<usize> = stdout(&o).split_whitespace().map(|v| v.parse().unwrap()).collect();
    let (n, bonds) = (printed[0], printed[1]);
    assert!(bonds > 0, "the scene must have bonds to draw");

    let out = dir.join("out");
    assert_eq!(check_vtp(&out.join("final.vtp"), n), (n, bonds), "one line per intact bond");

    let text = std::fs::read_to_string(out.join("tiny.pvd")).unwrap();
    let doc = Document::parse(&text).unwrap();
    assert_eq!(doc.root_element().attribute("type"), Some("Collection"));
    let sets: Vec<(f64, String)> = doc
        .descendants()
        .filter(|x| x.has_tag_name("DataSet"))
        .map(|x| (x.attribute("timestep").unwrap().parse().unwrap(), x.attribute("file").unwrap().to_string()))
        .collect();
    assert_eq!(sets.len(), 4, "steps 3000 to 5000 at one snapshot per 500: {sets:?}");
    assert!(sets.windows(2).all(|w| w[0].0 < w[1].0), "time order: {sets:?}");
    assert!(sets[0].1.ends_with("tiny_000003500.vtp"), "{sets:?}");
    for (_, file) in &sets {
        check_vtp(&out.join(file), n);
    }
}

#[test]
fn a_snapshot_name_that_is_not_a_plain_word_is_refused() {
    let dir = temp_dir("snapshots_bad");
    let script = dir.join("bad.rhai");
    std::fs::write(&script, SCRIPT.replace("d.snapshot_every(500);", "d.snapshot_every(500, \"a/b\");")).unwrap();
    let o = bin().arg("run").arg(&script).arg("--out").arg(dir.join("out")).output().unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("snapshot name `a/b` must be letters"), "{}", stderr(&o));
}
