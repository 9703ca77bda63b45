//! ParaView snapshots: the particles as VTK PolyData XML (`.vtp`) — one point per particle
//! with radius, velocity, displacement, force, group, material (and temperature, with heat on; water content, with moisture on), and each intact bond as a
//! line — and a `.pvd` collection that lists a series of them by time, so ParaView plays
//! them as an animation (open the `.pvd`, then apply a Glyph filter scaled by `radius`).

use matdem_engine::Model;
use std::fmt::Write;

/// The particles and bonds of `m` as a VTK PolyData XML file (ASCII).
pub fn vtp(m: &Model) -> String {
    let p = &m.particles;
    let n = p.len();
    let bonds: Vec<(usize, u32)> = (0..m.contacts.row_start.len().saturating_sub(1))
        .flat_map(|i| m.contacts.row(i).map(move |e| (i, e)))
        .filter(|&(i, e)| m.contacts.other[e] as usize > i && m.contacts.state[e].bonded)
        .map(|(i, e)| (i, m.contacts.other[e]))
        .collect();
    let groups: Vec<&str> = m.groups.names().collect();
    let mut group = vec![0i64; n];
    for (k, name) in groups.iter().enumerate() {
        for &i in m.groups.get(name).unwrap_or(&[]) {
            group[i as usize] = k as i64 + 1;
        }
    }
    let mut s = String::with_capacity(200 * n + 40 * bonds.len() + 1024);
    s.push_str("<?xml version=\"1.0\"?>\n");
    // NOTE: ids in `group` are 1 + the index in this list of the last group (by name) that
    // holds the particle; 0 for none.
    let names = groups.iter().enumerate().map(|(k, g)| format!("{} = {g}", k + 1)).collect::<Vec<_>>().join(", ");
    let _ = writeln!(s, "<!-- matdem-rs snapshot at step {}; group ids: {} -->", m.clock.step, xml_text(&names));
    s.push_str("<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n");
    s.push_str("  <PolyData>\n    <FieldData>\n");
    array(&mut s, "Float64", "TimeValue", 1, [m.clock.time].into_iter().map(num), " NumberOfTuples=\"1\"");
    s.push_str("    </FieldData>\n");
    let _ = writeln!(
        s,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{n}\" NumberOfLines=\"{}\" NumberOfStrips=\"0\" \
         NumberOfPolys=\"0\">",
        bonds.len()
    );
    s.push_str("      <PointData Scalars=\"radius\" Vectors=\"velocity\">\n");
    array(&mut s, "Float64", "radius", 1, p.radius.iter().map(|&r| num(r)), "");
    array(&mut s, "Float64", "velocity", 3, vec3(n, |i| p.vel[i]), "");
    array(&mut s, "Float64", "displacement", 3, vec3(n, |i| p.pos[i] - p.origin[i]), "");
    array(&mut s, "Float64", "force", 3, vec3(n, |i| p.force[i]), "");
    array(&mut s, "Int64", "group", 1, group.iter().map(|g| g.to_string()), "");
    array(&mut s, "Int64", "material", 1, p.material.iter().map(|k| k.to_string()), "");
    // 1 for an element `d.kill` removed (ParaView's Threshold filter hides them); only in a
    // model that has some.
    if (0..n).any(|i| m.is_killed(i)) {
        array(&mut s, "Int64", "killed", 1, (0..n).map(|i| u8::from(m.is_killed(i)).to_string()), "");
    }
    if m.settings.heat.enabled && p.thermal.temperature.len() == n {
        array(&mut s, "Float64", "temperature", 1, p.thermal.temperature.iter().map(|&t| num(t)), "");
    }
    if m.effects.moisture.settings.enabled && m.effects.moisture.lanes.water.len() == n {
        array(&mut s, "Float64", "water", 1, m.effects.moisture.lanes.water.iter().map(|&w| num(w)), "");
    }
    s.push_str("      </PointData>\n      <Points>\n");
    array(&mut s, "Float64", "position", 3, vec3(n, |i| p.pos[i]), "");
    s.push_str("      </Points>\n      <Verts>\n");
    array(&mut s, "Int64", "connectivity", 1, (0..n).map(|i| i.to_string()), "");
    array(&mut s, "Int64", "offsets", 1, (1..=n).map(|i| i.to_string()), "");
    s.push_str("      </Verts>\n      <Lines>\n");
    array(&mut s, "Int64", "connectivity", 1, bonds.iter().flat_map(|(i, j)| [i.to_string(), j.to_string()]), "");
    array(&mut s, "Int64", "offsets", 1, (1..=bonds.len()).map(|k| (2 * k).to_string()), "");
    s.push_str("      </Lines>\n    </Piece>\n  </PolyData>\n</VTKFile>\n");
    s
}

/// The pore network of `m` as a VTK PolyData XML file (ASCII), `None` when pore flow is off:
/// one point per pore at its centre (pressure, density, volume, region, and temperature with
/// heat on) and one line per throat between its two pores (conductance, flow from its first
/// pore to its second, opening, cracked). No vertex cells, so the cell data are the throats'
/// alone; show the pores with ParaView's Points or Point Gaussian representation.
pub fn pores_vtp(m: &Model) -> Option<String> {
    let f = m.pores.as_ref()?;
    let net = &f.network;
    let (np, nt) = (net.pore_count(), net.throats.len());
    let mut s = String::with_capacity(120 * np + 100 * nt + 1024);
    s.push_str("<?xml version=\"1.0\"?>\n");
    let _ = writeln!(
        s,
        "<!-- matdem-rs pore network at step {}: pores as points, throats as lines; region = the index of the \
         boundary region holding the pore (in the order they were set), -1 for none -->",
        m.clock.step
    );
    s.push_str("<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n");
    s.push_str("  <PolyData>\n    <FieldData>\n");
    array(&mut s, "Float64", "TimeValue", 1, [m.clock.time].into_iter().map(num), " NumberOfTuples=\"1\"");
    s.push_str("    </FieldData>\n");
    let _ = writeln!(
        s,
        "    <Piece NumberOfPoints=\"{np}\" NumberOfVerts=\"0\" NumberOfLines=\"{nt}\" NumberOfStrips=\"0\" \
         NumberOfPolys=\"0\">"
    );
    s.push_str("      <PointData Scalars=\"pressure\">\n");
    array(&mut s, "Float64", "pressure", 1, f.pressure.iter().map(|&p| num(p)), "");
    array(&mut s, "Float64", "density", 1, f.density().into_iter().map(num), "");
    array(&mut s, "Float64", "volume", 1, net.volume.iter().map(|&v| num(v)), "");
    array(&mut s, "Float64", "mass", 1, f.mass.iter().map(|&v| num(v)), "");
    if !f.temperature.is_empty() {
        array(&mut s, "Float64", "temperature", 1, f.temperature.iter().map(|&t| num(t)), "");
    }
    let region = |p: usize| if f.region[p] == u32::MAX { "-1".to_string() } else { f.region[p].to_string() };
    array(&mut s, "Int64", "region", 1, (0..np).map(region), "");
    s.push_str("      </PointData>\n      <CellData Scalars=\"conductance\">\n");
    array(&mut s, "Float64", "conductance", 1, net.conductance.iter().map(|&g| num(g)), "");
    array(&mut s, "Float64", "flux", 1, f.flow.iter().map(|&q| num(q)), "");
    array(&mut s, "Float64", "opening", 1, net.opening.iter().map(|&a| num(a)), "");
    array(&mut s, "Int64", "cracked", 1, net.cracked.iter().map(|&c| u8::from(c).to_string()), "");
    s.push_str("      </CellData>\n      <Points>\n");
    array(&mut s, "Float64", "position", 3, vec3(np, |p| net.centre[p]), "");
    s.push_str("      </Points>\n      <Lines>\n");
    array(&mut s, "Int64", "connectivity", 1, net.throats.iter().flat_map(|t| [t.a.to_string(), t.b.to_string()]), "");
    array(&mut s, "Int64", "offsets", 1, (1..=nt).map(|k| (2 * k).to_string()), "");
    s.push_str("      </Lines>\n    </Piece>\n  </PolyData>\n</VTKFile>\n");
    Some(s)
}

/// The components of a vector per particle, as text.
fn vec3(n: usize, f: impl Fn(usize) -> matdem_engine::Vec3) -> impl Iterator<Item = String> {
    (0..n).flat_map(move |i| {
        let v = f(i);
        [num(v.x), num(v.y), num(v.z)]
    })
}

/// A `.pvd` collection of snapshots: (time, file relative to the `.pvd`).
pub fn pvd(entries: &[(f64, String)]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  \
         <Collection>\n",
    );
    for (t, file) in entries {
        let _ =
            writeln!(s, "    <DataSet timestep=\"{}\" group=\"\" part=\"0\" file=\"{}\"/>", num(*t), xml_text(file));
    }
    s.push_str("  </Collection>\n</VTKFile>\n");
    s
}

/// Shortest text that reads back to the same number; VTK reads `nan` and `inf` too.
fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:?}")
    } else if x.is_nan() {
        "nan".into()
    } else if x > 0.0 {
        "inf".into()
    } else {
        "-inf".into()
    }
}

fn array(s: &mut String, ty: &str, name: &str, components: usize, values: impl Iterator<Item = String>, extra: &str) {
    let _ = write!(
        s,
        "        <DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{components}\"{extra} format=\"ascii\">"
    );
    for (k, v) in values.enumerate() {
        if k > 0 {
            s.push(' ');
        }
        s.push_str(&v);
    }
    s.push_str("</DataArray>\n");
}

/// Escapes text for XML attributes and comments (group names are the script's).
fn xml_text(t: &str) -> String {
    t.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;").replace("--", "- -")
}

/// The elements as a CSV table (`d.export_elements`): id, centre, radius, velocity, displacement since
/// the model was built, material name, the groups holding the element (`;`-separated, by
/// name) and 1 for an element `d.kill` removed (0 otherwise), one row per element; numbers in
/// the shortest form that reads back to the same f64.
pub fn elements_csv(m: &Model) -> String {
    let p = &m.particles;
    let n = p.len();
    let mut groups = vec![String::new(); n];
    for name in m.groups.names() {
        for &i in m.groups.get(name).unwrap_or(&[]) {
            let g = &mut groups[i as usize];
            if !g.is_empty() {
                g.push(';');
            }
            g.push_str(name);
        }
    }
    let mut w = csv::Writer::from_writer(Vec::new());
    let header = ["id", "x", "y", "z", "r", "vx", "vy", "vz", "dx", "dy", "dz", "material", "groups", "killed"];
    w.write_record(header).expect("a CSV record written to memory cannot fail");
    for i in 0..n {
        let (x, v, o) = (p.pos[i], p.vel[i], p.origin[i]);
        let material = m.materials.get(p.material[i] as usize).map_or("", |mat| mat.name.as_str());
        let nums = [x.x, x.y, x.z, p.radius[i], v.x, v.y, v.z, x.x - o.x, x.y - o.y, x.z - o.z];
        let mut row = vec![i.to_string()];
        row.extend(nums.iter().map(|v| format!("{v:?}")));
        row.push(material.to_string());
        row.push(groups[i].clone());
        row.push(u8::from(m.is_killed(i)).to_string());
        w.write_record(&row).expect("a CSV record written to memory cannot fail");
    }
    String::from_utf8(w.into_inner().expect("flushing a CSV writer into memory cannot fail"))
        .expect("CSV of UTF-8 names and numbers is UTF-8")
}
