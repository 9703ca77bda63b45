//! Fabric (`d.fabric(region)`): the fabric tensor of the contact normals (Satake/Oda), its
//! principal values and directions and the coordination number of a region
//! (`matdem_engine::analysis::fabric`); and the rose of the contact normals in a plane
//! (`d.rose(name, opts)`), a polar histogram saved as SVG and PNG.

use super::measure::{region, tensor, vector};
use super::*;
use crate::api::plot::save_figure;
use crate::plot::{Figure, Rose};
use matdem_engine::analysis::fabric;

/// The documentation of every name registered here: (name, usage, what it does).
pub const DOCS: &[(&str, &str, &str)] = &[
    ("fabric", "d.fabric() / d.fabric(region) -> map", "the fabric tensor of the contact normals F = (1/N_c)·Σ n ⊗ n (Satake, Oda) of the touching and bonded pairs, each counted once per element whose centre is in the region (a region map as in d.measure; the whole model without one): #{ tensor (3×3, trace 1), values (principal, largest first), directions (unit vectors), anisotropy (largest − smallest value), contacts, elements, coordination }; a perfect FCC interior gives I/3 and 12"),
    ("rose", "d.rose(name) / d.rose(name, #{ plane, weighted, bins, region })", "a rose diagram of the contact normals in a plane (plane \"xz\" by default, or \"xy\", \"yz\"): each contact's normal projected on the plane, counted at θ and θ + π in `bins` sectors (36), by number or, with weighted: true, by normal force; saves name.svg and name.png"),
];

/// The contacts of a region as (normal, normal force, weight = ends inside).
fn normals(d: &ModelHandle, region: Option<&Region>) -> Vec<(Vec3, f64, f64)> {
    let list = super::contacts::contact_list(d);
    let m = d.model();
    let p = &m.particles;
    let inside = |i: usize| !m.is_killed(i) && region.is_none_or(|r| r.contains(&p.pos[i]));
    list.rows
        .iter()
        .filter(|r| r.is_active())
        .filter_map(|r| {
            let j = r.j()? as usize;
            let w = f64::from(u8::from(inside(r.i as usize)) + u8::from(inside(j)));
            (w > 0.0).then_some((r.normal, r.normal_force, w))
        })
        .collect()
}

fn fabric_map(d: &ModelHandle, region: Option<&Region>) -> RhaiResult<Map> {
    let list = super::contacts::contact_list(d);
    let f = fabric(&d.model(), &list, region).map_err(raise)?;
    let mut map = Map::new();
    map.insert("tensor".into(), Dynamic::from_array(tensor(&f.tensor)));
    map.insert("values".into(), Dynamic::from_array(f.values.iter().map(|v| Dynamic::from_float(*v)).collect()));
    map.insert(
        "directions".into(),
        Dynamic::from_array(f.directions.iter().map(|v| Dynamic::from_array(vector(v))).collect()),
    );
    map.insert("anisotropy".into(), Dynamic::from_float(f.values[0] - f.values[2]));
    map.insert("contacts".into(), Dynamic::from_float(f.contacts));
    map.insert("elements".into(), Dynamic::from_int(f.elements as INT));
    map.insert("coordination".into(), Dynamic::from_float(f.coordination));
    Ok(map)
}

/// `d.rose`'s options.
struct RoseOptions {
    axes: [usize; 2],
    plane: String,
    weighted: bool,
    bins: usize,
    region: Option<Region>,
}

fn rose_options(opts: &Map) -> RhaiResult<RoseOptions> {
    let mut o = RoseOptions { axes: [0, 2], plane: "xz".into(), weighted: false, bins: 36, region: None };
    for (k, v) in opts {
        match k.as_str() {
            "plane" => {
                let s = v.clone().into_string().map_err(|_| err("rose: `plane` is \"xz\", \"xy\" or \"yz\""))?;
                o.axes = match s.as_str() {
                    "xz" => [0, 2],
                    "xy" => [0, 1],
                    "yz" => [1, 2],
                    _ => return Err(err(format!("rose: plane \"{s}\"; give \"xz\", \"xy\" or \"yz\""))),
                };
                o.plane = s;
            }
            "weighted" => o.weighted = v.as_bool().map_err(|_| err("rose: `weighted` is true or false"))?,
            "bins" => {
                o.bins = v
                    .as_int()
                    .ok()
                    .filter(|b| (4..=360).contains(b))
                    .ok_or_else(|| err(format!("rose: bins = {v}; give a whole number from 4 to 360")))?
                    as usize
            }
            "region" => o.region = Some(region(v, "rose")?),
            other => {
                return Err(err(format!(
                    "rose: unknown option `{other}`; the options are plane, weighted, bins, region"
                )))
            }
        }
    }
    Ok(o)
}

fn draw_rose(h: &Host, d: &ModelHandle, name: &str, o: &RoseOptions) -> RhaiResult<Dynamic> {
    let contacts = normals(d, o.region.as_ref());
    if contacts.is_empty() {
        return Err(err("rose: no contact in the region, so no normal to draw"));
    }
    let [a, b] = o.axes;
    let names = ["x", "y", "z"];
    let rose = Rose {
        title: format!("{} — contact normals in the {} plane", d.data().name, o.plane),
        axes: [names[a].to_string(), names[b].to_string()],
        measure: if o.weighted { "Σ normal force [N]".into() } else { "contacts".into() },
        angles: contacts.iter().map(|(n, _, _)| n[b].atan2(n[a])).collect(),
        weights: contacts.iter().map(|(_, f, w)| if o.weighted { f.max(0.0) * w } else { *w }).collect(),
        bins: o.bins,
    };
    save_figure(h, name, |p| rose.save(p))
}

pub(super) fn register(engine: &mut Engine, host: &Rc<Host>) {
    engine.register_fn("fabric", observed!(host, "fabric", |d| fabric_map(d, None)?));
    let h = host.clone();
    engine.register_fn("fabric", move |d: &mut ModelHandle, r: Dynamic| -> RhaiResult<Dynamic> {
        let region = region(&r, "fabric")?;
        h.observe("fabric", || fabric_map(d, Some(&region)).map(Dynamic::from_map))
    });
    let h = host.clone();
    engine.register_fn("rose", move |d: &mut ModelHandle, name: &str| -> RhaiResult<Dynamic> {
        let o = rose_options(&Map::new())?;
        h.observe("rose", || draw_rose(&h, d, name, &o))
    });
    let h = host.clone();
    engine.register_fn("rose", move |d: &mut ModelHandle, name: &str, opts: Map| -> RhaiResult<Dynamic> {
        let o = rose_options(&opts)?;
        h.observe("rose", || draw_rose(&h, d, name, &o))
    });
}
