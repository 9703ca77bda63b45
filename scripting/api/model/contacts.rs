//! The contact table (`d.contacts()`): one row per contact or bond, evaluated by the engine's
//! contact laws from the model as it stands (`matdem_engine::analysis::contact_list`), and the
//! lanes of each element's contact force and torque sums (`d.contact_fx` …), which are the
//! table's forces summed; also the last step's torque lanes (`d.tx` …), beside `d.fx`; and
//! the force chain picture (`d.show_force_chains`).
//!
//! Reading them is an observation (journaled for resume): the table is journaled as its
//! columns and rebuilt from them.

use super::*;
use crate::api::plot::save_figure;
use crate::plot::{Figure, ForceChainPicture};
use matdem_engine::analysis::{ContactList, Other};
use matdem_engine::WallShape;

/// The documentation of every name registered here: (name, usage, what it does).
pub const DOCS: &[(&str, &str, &str)] = &[
    ("contacts", "d.contacts() / d.contacts(group or ids or mask) -> Table", "one row per contact (touching pair, intact bond, element on a wall) or broken bond, evaluated by the contact laws from the model as it stands: i, j (NaN for a wall), wall (its name, or empty), x y z (contact point, m), nx ny nz (unit normal from i), overlap (m, < 0 for a stretched bond), fn (normal force, N, compression > 0), fs_x fs_y fs_z and fs (shear force on i and its magnitude, N), fx fy fz (whole force on i, N; j feels the opposite), bonded (1 intact, else 0), bond (none, intact, broken_tension, broken_shear); with a selection, the rows that touch it. Save it with t.save(\"contacts.csv\")"),
    ("show_force_chains", "d.show_force_chains(name) / d.show_force_chains(name, #{ slice, threshold })", "a picture (name.svg, name.png) of the x–z section |y − ȳ| ≤ slice (m; the mean radius by default) with a line between the centres of each compressed pair whose contact point lies in it, width and colour by the normal force; chains under threshold × the mean normal force (0 by default) are left out; walls drawn where they cut the section (planes, the ring)"),
];

/// The documentation of every property registered here: (name, of, what it is).
pub const PROPERTIES: &[(&str, &str, &str)] = &[
    ("contact_fx", "Model (read)", "sum of the contact forces (elements and walls) on every element, x, N, as d.contacts() evaluates them now (d.fx is the last step's resultant); also contact_fy, contact_fz"),
    ("contact_fy", "Model (read)", "sum of the contact forces on every element, y, N"),
    ("contact_fz", "Model (read)", "sum of the contact forces on every element, z, N"),
    ("contact_tx", "Model (read)", "sum of the contact torques (r·n) × F_t about every element's centre, x, N·m, whether or not rotation is on; also contact_ty, contact_tz"),
    ("contact_ty", "Model (read)", "sum of the contact torques on every element, y, N·m"),
    ("contact_tz", "Model (read)", "sum of the contact torques on every element, z, N·m"),
    ("tx", "Model (read)", "resultant torque x on every element in the last step, N·m (rotation on); also ty, tz"),
    ("deepest_overlap", "Model (read)", "the deepest overlap of two touching elements: #{ share (overlap over the smaller radius, 0 when none touches), i, j (the pair, () when none), limit (the share above which the guard stops the run, 0.5) }; a procedure that loads until something gives can stop before the guard does (examples/cpt stops the cone at 0.9 of the limit)"),
    ("ty", "Model (read)", "resultant torque y on every element in the last step, N·m"),
    ("tz", "Model (read)", "resultant torque z on every element in the last step, N·m"),
];

/// The contact list of the model as it stands (rows rebuilt first if they are stale).
pub(crate) fn contact_list(d: &ModelHandle) -> ContactList {
    d.data().sim.contact_list()
}

/// The table's columns, in order: (name, numbers) or (name, text) as a journaled array.
fn columns(d: &ModelHandle, sel: Option<&[u32]>) -> Array {
    let list = contact_list(d);
    let m = d.model();
    let keep: Option<Vec<bool>> = sel.map(|ids| {
        let mut k = vec![false; m.len()];
        ids.iter().for_each(|&i| k[i as usize] = true);
        k
    });
    let rows: Vec<_> = list
        .rows
        .iter()
        .filter(|r| keep.as_ref().is_none_or(|k| k[r.i as usize] || r.j().is_some_and(|j| k[j as usize])))
        .collect();
    let num = |name: &str, f: &dyn Fn(&matdem_engine::analysis::ContactRow) -> f64| -> Dynamic {
        Dynamic::from_array(vec![name.into(), Dynamic::from(Field::new(rows.iter().map(|r| f(r)).collect()))])
    };
    let text = |name: &str, f: &dyn Fn(&matdem_engine::analysis::ContactRow) -> String| -> Dynamic {
        let values: Array = rows.iter().map(|r| Dynamic::from(f(r))).collect();
        Dynamic::from_array(vec![name.into(), Dynamic::from_array(values)])
    };
    vec![
        num("i", &|r| r.i as f64),
        num("j", &|r| r.j().map_or(f64::NAN, f64::from)),
        text("wall", &|r| match r.other {
            Other::Wall(w) => m.walls[w].name.clone(),
            Other::Element(_) => String::new(),
        }),
        num("x", &|r| r.point.x),
        num("y", &|r| r.point.y),
        num("z", &|r| r.point.z),
        num("nx", &|r| r.normal.x),
        num("ny", &|r| r.normal.y),
        num("nz", &|r| r.normal.z),
        num("overlap", &|r| r.overlap),
        num("fn", &|r| r.normal_force),
        num("fs_x", &|r| r.shear_force.x),
        num("fs_y", &|r| r.shear_force.y),
        num("fs_z", &|r| r.shear_force.z),
        num("fs", &|r| r.shear_force.norm()),
        num("fx", &|r| r.force.x),
        num("fy", &|r| r.force.y),
        num("fz", &|r| r.force.z),
        num("bonded", &|r| f64::from(u8::from(r.bond == matdem_engine::analysis::Bond::Intact))),
        text("bond", &|r| r.bond.name().to_string()),
    ]
}

/// A table from the journaled columns of [`columns`].
fn table_of(cols: Array) -> RhaiResult<Table> {
    let mut numbers = Vec::new();
    let mut texts = Vec::new();
    let mut rows = 0;
    for c in cols {
        let pair = c.try_cast::<Array>().ok_or_else(|| err("internal error: a contact column is not a pair"))?;
        let name = pair[0].clone().into_string().map_err(|_| err("internal error: a contact column has no name"))?;
        if let Some(f) = pair[1].clone().try_cast::<Field>() {
            rows = f.0.len();
            numbers.push((name, f.0.to_vec()));
        } else if let Some(a) = pair[1].clone().try_cast::<Array>() {
            texts.push((name, numbers.len(), a.into_iter().map(|v| v.to_string()).collect::<Vec<String>>()));
        }
    }
    let mut t = TableData::from_columns(numbers, rows);
    for (name, at, values) in texts {
        t = t.with_text(&name, at, values);
    }
    Ok(Table(Rc::new(RefCell::new(t))))
}

/// The segment of the line a·x + b·z = c (in the view's plane) inside the box
/// [x0, x1] × [z0, z1], if it crosses it.
fn clip_line(a: f64, b: f64, c: f64, (x0, x1, z0, z1): (f64, f64, f64, f64)) -> Option<((f64, f64), (f64, f64))> {
    let mut pts = Vec::new();
    if b != 0.0 {
        for x in [x0, x1] {
            let z = (c - a * x) / b;
            if (z0..=z1).contains(&z) {
                pts.push((x, z));
            }
        }
    }
    if a != 0.0 {
        for z in [z0, z1] {
            let x = (c - b * z) / a;
            if (x0..=x1).contains(&x) {
                pts.push((x, z));
            }
        }
    }
    pts.dedup();
    (pts.len() >= 2).then(|| (pts[0], pts[pts.len() - 1]))
}

/// `d.show_force_chains`' picture.
fn force_chains(d: &ModelHandle, slice: Option<f64>, threshold: f64) -> RhaiResult<ForceChainPicture> {
    let list = contact_list(d);
    let data = d.data();
    let m = &data.sim.model;
    let p = &m.particles;
    let live: Vec<usize> = (0..p.len()).filter(|&i| !m.is_killed(i)).collect();
    if live.is_empty() {
        return Err(err("show_force_chains: the model has no elements"));
    }
    let y_mid = live.iter().map(|&i| p.pos[i].y).sum::<f64>() / live.len() as f64;
    let w = slice.unwrap_or_else(|| live.iter().map(|&i| p.radius[i]).sum::<f64>() / live.len() as f64);
    let in_slice = |y: f64| (y - y_mid).abs() <= w;
    let elements: Vec<(f64, f64, f64)> =
        live.iter().filter(|&&i| in_slice(p.pos[i].y)).map(|&i| (p.pos[i].x, p.pos[i].z, p.radius[i])).collect();
    if elements.is_empty() {
        return Err(err(format!(
            "show_force_chains: no element within {w:e} m of the mid-plane y = {y_mid:e}; widen the slice"
        )));
    }
    let mut chains: Vec<crate::plot::force_chains::Chain> = list
        .rows
        .iter()
        .filter(|r| r.is_active() && r.normal_force > 0.0 && in_slice(r.point.y))
        .filter_map(|r| {
            let (a, b) = (p.pos[r.i as usize], p.pos[r.j()? as usize]);
            Some(((a.x, a.z), (b.x, b.z), r.normal_force))
        })
        .collect();
    let mean = chains.iter().map(|c| c.2).sum::<f64>() / chains.len().max(1) as f64;
    chains.retain(|c| c.2 >= threshold * mean);
    let (mut x0, mut x1, mut z0, mut z1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, z, r) in &elements {
        (x0, x1, z0, z1) = (x0.min(x - r), x1.max(x + r), z0.min(z - r), z1.max(z + r));
    }
    let pad = 0.03 * (x1 - x0).max(z1 - z0);
    let view = (x0 - pad, x1 + pad, z0 - pad, z1 + pad);
    let mut walls = Vec::new();
    for wall in &m.walls {
        match &wall.shape {
            WallShape::Plane { point, normal } => {
                let c = point.dot(normal) - normal.y * y_mid;
                walls.extend(clip_line(normal.x, normal.z, c, view));
            }
            WallShape::Cylinder { center, radius } => {
                let h2 = radius * radius - (y_mid - center.y).powi(2);
                if h2 > 0.0 {
                    for x in [center.x - h2.sqrt(), center.x + h2.sqrt()] {
                        walls.extend(clip_line(1.0, 0.0, x, view));
                    }
                }
            }
            // NOTE: cones and strips are not drawn (no example needs them in a force chain picture yet).
            WallShape::Cone { .. } | WallShape::Strip { .. } => {}
        }
    }
    let kept = if threshold > 0.0 { format!(", chains ≥ {threshold} × mean") } else { String::new() };
    Ok(ForceChainPicture {
        title: format!("{} — force chains (slice |y − ȳ| ≤ {w:.2e} m{kept})", data.name),
        x_label: "x [m]".into(),
        y_label: "z [m]".into(),
        elements,
        chains,
        walls,
    })
}

fn chain_options(opts: &Map) -> RhaiResult<(Option<f64>, f64)> {
    let (mut slice, mut threshold) = (None, 0.0);
    for (k, v) in opts {
        let x = number(v)
            .filter(|x| x.is_finite())
            .ok_or_else(|| err(format!("show_force_chains: `{k}` must be a finite number, got {v}")))?;
        match k.as_str() {
            "slice" if x > 0.0 => slice = Some(x),
            "slice" => return Err(err(format!("show_force_chains: the slice half-width must be > 0 m, got {x}"))),
            "threshold" if x >= 0.0 => threshold = x,
            "threshold" => {
                return Err(err(format!(
                    "show_force_chains: threshold must be ≥ 0 (a fraction of the mean normal force), got {x}"
                )))
            }
            other => {
                return Err(err(format!(
                    "show_force_chains: unknown option `{other}`; the options are slice, threshold"
                )))
            }
        }
    }
    Ok((slice, threshold))
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    let h = host.clone();
    engine.register_fn("show_force_chains", move |d: &mut ModelHandle, name: &str| -> RhaiResult<Dynamic> {
        h.observe("show_force_chains", || {
            let pic = force_chains(d, None, 0.0)?;
            save_figure(&h, name, |p| pic.save(p))
        })
    });
    let h = host.clone();
    engine.register_fn("show_force_chains", move |d: &mut ModelHandle, name: &str, opts: Map| -> RhaiResult<Dynamic> {
        let (slice, threshold) = chain_options(&opts)?;
        h.observe("show_force_chains", || {
            let pic = force_chains(d, slice, threshold)?;
            save_figure(&h, name, |p| pic.save(p))
        })
    });
    let h = host.clone();
    engine.register_fn("contacts", move |d: &mut ModelHandle| -> RhaiResult<Table> {
        let cols = h.observe("contacts", || Ok(Dynamic::from_array(columns(d, None))))?;
        table_of(cols.cast::<Array>())
    });
    let h = host.clone();
    engine.register_fn("contacts", move |d: &mut ModelHandle, sel: Dynamic| -> RhaiResult<Table> {
        let ids = resolve_ids(&d.model(), &sel)?;
        let cols = h.observe("contacts", || Ok(Dynamic::from_array(columns(d, Some(&ids)))))?;
        table_of(cols.cast::<Array>())
    });
    let h = host.clone();
    engine.register_get("deepest_overlap", move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
        h.observe("deepest_overlap", || {
            let m = d.model();
            let deepest = matdem_engine::guard::deepest_overlap(&m);
            let mut map = Map::new();
            let id = |k: usize| Dynamic::from_int(k as INT);
            map.insert("share".into(), Dynamic::from_float(deepest.map_or(0.0, |o| o.share)));
            map.insert("i".into(), deepest.map_or(Dynamic::UNIT, |o| id(o.i)));
            map.insert("j".into(), deepest.map_or(Dynamic::UNIT, |o| id(o.j)));
            map.insert("limit".into(), Dynamic::from_float(m.settings.max_overlap_ratio));
            Ok(Dynamic::from_map(map))
        })
    });
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        let (h, name): (_, &'static str) = (host.clone(), ["contact_fx", "contact_fy", "contact_fz"][k]);
        engine.register_get(name, move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
            h.observe(name, || Ok(Dynamic::from(Field::new(contact_list(d).force.iter().map(|f| f[k]).collect()))))
        });
        let (h, name): (_, &'static str) = (host.clone(), ["contact_tx", "contact_ty", "contact_tz"][k]);
        engine.register_get(name, move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
            h.observe(name, || Ok(Dynamic::from(Field::new(contact_list(d).torque.iter().map(|t| t[k]).collect()))))
        });
        let (h, name): (_, &'static str) = (host.clone(), ["tx", "ty", "tz"][k]);
        engine.register_get(name, move |d: &mut ModelHandle| -> RhaiResult<Dynamic> {
            h.observe(name, || {
                let m = d.model();
                let rot = m.particles.rotation.as_ref().ok_or_else(|| {
                    err(format!(
                        "`t{axis}`: rotation is off, so no step computed torques; switch it on with \
                         d.enable(\"rotation\"), or read the contacts' torques with d.contact_t{axis}"
                    ))
                })?;
                Ok(Dynamic::from(Field::new(rot.torque.iter().map(|t| t[k]).collect())))
            })
        });
    }
}
