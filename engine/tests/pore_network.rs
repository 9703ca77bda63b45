//! The pore network's geometry: the Delaunay tetrahedralisation it rests on (empty
//! circumspheres, volume equal to the convex hull, co-spherical lattices handled), pore
//! volumes against the known porosity of regular packings, and the pore-pressure forces
//! (zero on an interior element under uniform pressure, p × the face's area on a hull face).

use matdem_engine::effects::pore_flow::delaunay::{tetrahedralise, Tetrahedralisation, HULL};
use matdem_engine::effects::pore_flow::pressure_forces::add_pressure_forces;
use matdem_engine::effects::pore_flow::{Fluid, PoreFlow, PoreNetwork};
use matdem_engine::physics::Vec3;
use matdem_engine::{Material, Model};
use std::f64::consts::PI;

/// Deterministic points in the unit cube (an LCG), plus its 8 corners.
fn cube_and_random(n: usize) -> Vec<Vec3> {
    let mut s = 0x2545_F491_4F6C_DD1Du64;
    let mut r = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut p: Vec<Vec3> =
        (0..8).map(|c| Vec3::new((c & 1) as f64, ((c >> 1) & 1) as f64, ((c >> 2) & 1) as f64)).collect();
    for _ in 0..n {
        p.push(Vec3::new(r(), r(), r()));
    }
    p
}

fn simple_cubic(n: usize, a: f64) -> Vec<Vec3> {
    let mut p = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                p.push(Vec3::new(i as f64, j as f64, k as f64) * a);
            }
        }
    }
    p
}

/// FCC conventional cells, n × n × n, with every lattice point of the closed block.
fn fcc(n: usize, a: f64) -> Vec<Vec3> {
    let mut p = Vec::new();
    let h = 2 * n;
    for i in 0..=h {
        for j in 0..=h {
            for k in 0..=h {
                if (i + j + k) % 2 == 0 {
                    p.push(Vec3::new(i as f64, j as f64, k as f64) * (a / 2.0));
                }
            }
        }
    }
    p
}

/// Checks mutual neighbour links and positive orientation, and returns the largest
/// violation of the empty-circumsphere property, as a fraction of the circumradius.
fn check(tri: &Tetrahedralisation, pts: &[Vec3]) -> f64 {
    for (t, tet) in tri.tets.iter().enumerate() {
        for k in 0..4 {
            let nb = tet.n[k];
            if nb != HULL {
                assert!(tri.tets[nb as usize].n.contains(&(t as u32)), "tet {t}'s neighbour {nb} does not link back");
            }
        }
        let j = tet.v.map(|i| Vec3::from(tri.points[i as usize]));
        assert!((j[0] - j[3]).dot(&(j[1] - j[3]).cross(&(j[2] - j[3]))) > 0.0, "tet {t} is not positively oriented");
    }
    let mut worst: f64 = 0.0;
    for tet in &tri.tets {
        let [a, b, c, d] = tet.v.map(|i| Vec3::from(tri.points[i as usize]));
        // Circumcentre: solve 2(b−a)·x = |b|²−|a|², ….
        let m = nalgebra::Matrix3::from_rows(&[(b - a).transpose(), (c - a).transpose(), (d - a).transpose()]) * 2.0;
        let rhs = Vec3::new(
            b.norm_squared() - a.norm_squared(),
            c.norm_squared() - a.norm_squared(),
            d.norm_squared() - a.norm_squared(),
        );
        let Some(x) = m.lu().solve(&rhs) else { continue };
        let r = (a - x).norm();
        for (i, p) in pts.iter().enumerate() {
            if tet.v.contains(&(i as u32)) {
                continue;
            }
            let inside = (r - (p - x).norm()) / r;
            worst = worst.max(inside);
        }
    }
    worst
}

fn total_volume(tri: &Tetrahedralisation, pos: &[Vec3]) -> f64 {
    (0..tri.tets.len()).map(|t| tri.volume(t, pos)).sum()
}

#[test]
fn random_points_give_empty_circumspheres_and_fill_their_hull() {
    let pts = cube_and_random(400);
    let tri = tetrahedralise(&pts).unwrap();
    let worst = check(&tri, &pts);
    // The jitter moves points by 1e-9 of the diagonal; nothing else may sit inside.
    assert!(worst < 1e-7, "a point lies {worst:.2e} of a circumradius inside a circumsphere");
    let v = total_volume(&tri, &pts);
    assert!((v - 1.0).abs() < 1e-6, "volume {v} ≠ the hull's 1");
    // Every point is a corner of some tetrahedron.
    let mut used = vec![false; pts.len()];
    tri.tets.iter().for_each(|t| t.v.iter().for_each(|&i| used[i as usize] = true));
    assert!(used.iter().all(|&u| u));
}

#[test]
fn cospherical_lattices_are_tetrahedralised_through_the_jitter() {
    for (name, pts, hull) in [("simple cubic", simple_cubic(6, 1.0), 125.0), ("fcc", fcc(3, 1.0), 27.0)] {
        let tri = tetrahedralise(&pts).unwrap();
        let worst = check(&tri, &pts);
        assert!(worst < 1e-7, "{name}: a point lies {worst:.2e} of a circumradius inside a circumsphere");
        let v = total_volume(&tri, &pts);
        assert!((v / hull - 1.0).abs() < 1e-6, "{name}: volume {v} ≠ the hull's {hull}");
        println!("{name}: {} points, {} tetrahedra", pts.len(), tri.tets.len());
    }
}

#[test]
fn too_few_or_coincident_points_are_refused_with_a_message() {
    let e = tetrahedralise(&[Vec3::zeros(), Vec3::x(), Vec3::y()]).unwrap_err().to_string();
    assert!(e.contains("at least 4 elements"), "{e}");
    let e = tetrahedralise(&[Vec3::zeros(); 5]).unwrap_err().to_string();
    assert!(e.contains("distinct positions"), "{e}");
}

/// A model of equal spheres of radius `r` at the given centres.
fn model(pts: &[Vec3], r: f64) -> Model {
    let mut m = Model::new();
    let mat = m.add_material(Material::from_micro("grain", 2650.0, 1e6, 4e5, 0.0, 0.0, 0.5, r).unwrap()).unwrap();
    for p in pts {
        m.add_particle(*p, r, mat).unwrap();
    }
    m
}

#[test]
fn pore_volume_of_regular_packings_matches_their_porosity() {
    // Touching spheres; the hull of the centres holds a whole number of spheres per cell.
    let a = 1e-3;
    let n = 5;
    let m = model(&simple_cubic(n + 1, a), a / 2.0);
    let net = PoreNetwork::build(&m).unwrap();
    let want = (n as f64 * a).powi(3) * (1.0 - PI / 6.0);
    let got: f64 = net.volume.iter().sum();
    assert!((got / want - 1.0).abs() < 1e-6, "simple cubic pore volume {got:e} vs {want:e}");

    let r = a / (2.0 * 2f64.sqrt());
    let m = model(&fcc(3, a), r);
    let net = PoreNetwork::build(&m).unwrap();
    let want = (3.0 * a).powi(3) * (1.0 - PI / (3.0 * 2f64.sqrt()));
    let got: f64 = net.volume.iter().sum();
    assert!((got / want - 1.0).abs() < 1e-6, "fcc pore volume {got:e} vs {want:e}");
    println!("fcc: {} tetrahedra in {} pores, {} throats", net.tri.tets.len(), net.pore_count(), net.throats.len());
}

#[test]
fn uniform_pressure_pushes_only_on_the_hull() {
    let a = 1e-3;
    let n = 5;
    let r = 0.45 * a;
    let pts = simple_cubic(n + 1, a);
    let m = model(&pts, r);
    let flow = PoreFlow::new(&m, Fluid::default()).unwrap();
    let p = 1e5;
    let pressure = vec![p; flow.network.pore_count()];
    let mut force = vec![Vec3::zeros(); pts.len()];
    add_pressure_forces(&flow.network, &pressure, &m.particles.pos, &mut force);
    let top = n as f64 * a;
    let on_hull = |x: &Vec3| (0..3).any(|d| x[d] < 1e-9 || x[d] > top - 1e-9);
    for (i, x) in pts.iter().enumerate() {
        if !on_hull(x) {
            assert!(force[i].norm() < 1e-9 * p * r * r, "interior element {i} feels {:?}", force[i]);
        }
    }
    // The top face carries p × its whole area (n a)², shared by its elements: the sectors the
    // spheres cut from it and the openings between them (the throats' share, carried by their
    // corners), so the skeleton takes the whole pressure (Biot's coefficient 1).
    let fz: f64 = pts.iter().zip(&force).filter(|(x, _)| x.z > top - 1e-9).map(|(_, f)| f.z).sum();
    let want = p * (n * n) as f64 * a * a;
    assert!((fz / want - 1.0).abs() < 1e-6, "top force {fz:e} vs p × face area {want:e}");
    // An interior element of the top face: p × a² (four quarter squares).
    let mid = pts.iter().position(|x| x.z > top - 1e-9 && (x.x - 2.0 * a).abs() < 1e-9 && (x.y - 2.0 * a).abs() < 1e-9);
    let fm = force[mid.unwrap()];
    assert!((fm.z / (p * a * a) - 1.0).abs() < 1e-6 && fm.x.abs() < 1e-6 * p * a * a, "{fm:?}");
    let total: Vec3 = force.iter().sum();
    assert!(total.norm() < 1e-9 * want, "net force {total:?} on a closed, uniformly pressurised sample");
}

/// A layer of touching spheres (nx × 3, radius 0.5) with a column at each end of a second
/// layer: the convex hull bridges the dip between the columns with wide flat tetrahedra.
fn layer_with_end_columns(nx: usize) -> Vec<Vec3> {
    let mut p = Vec::new();
    for i in 0..nx {
        for j in 0..3 {
            p.push(Vec3::new(i as f64, j as f64, 0.0));
            if i == 0 || i == nx - 1 {
                p.push(Vec3::new(i as f64, j as f64, 1.0));
            }
        }
    }
    p
}

/// The gap between two spheres of an edge of tetrahedron `t`, the widest, in diameters.
fn widest_gap(tri: &Tetrahedralisation, pts: &[Vec3], r: f64, t: usize) -> f64 {
    let v = tri.tets[t].v.map(|i| pts[i as usize]);
    let mut gap: f64 = 0.0;
    for a in 0..4 {
        for b in a + 1..4 {
            gap = gap.max(((v[a] - v[b]).norm() - 2.0 * r) / (2.0 * r));
        }
    }
    gap
}

// The hull's bridge over a dip is open space, not a pore: before, its flat tetrahedra (a
// facet 0.4 m across over 15 mm grains in the hydraulic fracture) were pores whose small
// volume under a wide face made the fluid a spring 400 × stiffer than the contacts.
#[test]
fn the_hulls_bridge_over_a_dip_is_not_a_pore() {
    let r = 0.5;
    let pts = layer_with_end_columns(9);
    let raw = tetrahedralise(&pts).unwrap();
    let bridged = (0..raw.tets.len()).filter(|&t| widest_gap(&raw, &pts, r, t) > 2.0).count();
    assert!(bridged > 0, "the convex hull should bridge the dip");
    let net = PoreNetwork::build(&model(&pts, r)).unwrap();
    let widest = (0..net.tri.tets.len()).map(|t| widest_gap(&net.tri, &pts, r, t)).fold(0.0, f64::max);
    assert!(widest <= 2.0, "a pore spans a gap of {widest:.2} diameters");
    assert!(net.tri.tets.len() < raw.tets.len() && net.pore_count() > 0);
    println!(
        "{} of {} tetrahedra bridge the dip; {} remain in {} pores",
        bridged,
        raw.tets.len(),
        net.tri.tets.len(),
        net.pore_count()
    );
}

// Every pore keeps room: a pore under SMALL_PORE_FRACTION of the mean tetrahedron's room
// merges with neighbours until it is not (before, a small tetrahedron merged once, into a
// neighbour that could itself be small, and a hull sliver's sector lay outside the packing).
#[test]
fn no_pore_of_a_random_packing_has_a_vanishing_volume() {
    use matdem_engine::effects::pore_flow::geometry::pore_volume;
    use matdem_engine::effects::pore_flow::network::SMALL_PORE_FRACTION;
    // Spheres of radius 0.06 at random points of the unit cube, kept where they overlap no
    // other by more than a tenth of a radius (a dense, irregular packing with a rough hull).
    let r = 0.06;
    let mut pts: Vec<Vec3> = Vec::new();
    for p in cube_and_random(4000) {
        if pts.iter().all(|q| (p - q).norm() > 1.9 * r) {
            pts.push(p);
        }
    }
    let m = model(&pts, r);
    let net = PoreNetwork::build(&m).unwrap();
    let tets = &net.tri.tets;
    let mean =
        tets.iter().map(|t| pore_volume(t.v.map(|i| pts[i as usize]), [r; 4], 0.0)).sum::<f64>() / tets.len() as f64;
    let least = net.volume.iter().cloned().fold(f64::MAX, f64::min);
    println!(
        "{} spheres, {} pores; least pore volume {:.3} of the mean tetrahedron's room",
        pts.len(),
        net.pore_count(),
        least / mean
    );
    assert!(least >= SMALL_PORE_FRACTION * mean * (1.0 - 1e-9), "a pore of {:.3e} against the mean {mean:.3e}", least);
}
