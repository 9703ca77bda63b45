//! The parallel-bond law (Potyondy & Cundall 2004; PFC 5's linear parallel bond, 3-D): a
//! cylinder of cement of radius R̄ = λ̄·min(R₁, R₂) between two elements, in parallel with
//! their linear contact, that carries a normal and a shear force and a twisting and a bending
//! moment, each updated from the increment of relative motion, and breaks in tension or shear.
//! The formulas and conventions are in docs/parallel-bond.md; this file is their one
//! implementation on the CPU (shaders/parallel_bond.wgsl is its f32 twin).
//!
//! Every bond is evaluated in one canonical orientation, from its lower id towards its higher
//! id, whichever particle's row asks: both rows then hold the very same state, bit for bit, and
//! take the same breaking decision, and each particle applies its side of the result.

use crate::physics::contact_law::rotate_into_plane;
use crate::physics::Vec3;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The six micro parameters of the parallel bond (the paper's Table 1 less μ, which is the
/// linear contact's). SI units; `phi` in radians.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ParallelBondParams {
    /// Radius multiplier λ̄: the bond's radius is λ̄·min(R₁, R₂).
    pub lambda: f64,
    /// Bond effective modulus Ē* (Pa): normal stiffness per area k̄n = Ē*/(R₁ + R₂).
    pub e_star: f64,
    /// Bond stiffness ratio k̄* = k̄n/k̄s.
    pub k_ratio: f64,
    /// Tensile strength σ̄c (Pa).
    pub sigma_c: f64,
    /// Cohesion c̄ (Pa).
    pub cohesion: f64,
    /// Friction angle φ̄ (rad): the shear strength is c̄ − σ̄n·tan φ̄ (σ̄n tension positive).
    pub phi: f64,
}

impl ParallelBondParams {
    /// Checks every parameter, naming the bad one and its valid range.
    pub fn validate(&self) -> Result<(), String> {
        let checks = [
            ("lambda", self.lambda, "a radius multiplier > 0 (PFC: 1)"),
            ("e_star", self.e_star, "an effective modulus > 0 (Pa)"),
            ("k_ratio", self.k_ratio, "a stiffness ratio k̄n/k̄s > 0 (2.6 for ν = 0.3)"),
            ("sigma_c", self.sigma_c, "a tensile strength > 0 (Pa)"),
            ("c", self.cohesion, "a cohesion > 0 (Pa)"),
        ];
        for (name, v, what) in checks {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("parallel bond `{name}` = {v}: give {what}"));
            }
        }
        // Past these the bond's arithmetic leaves the numbers (a section of 1e-300 m has no
        // area; k̄s = k̄n/1e-300 no finite stiffness); no rock comes near them.
        let ranges = [
            ("lambda", self.lambda, 0.01, 10.0, "a radius multiplier (PFC: 1)"),
            ("e_star", self.e_star, 1.0, 1e13, "an effective modulus in Pa (granite: ~5e10)"),
            ("k_ratio", self.k_ratio, 0.01, 100.0, "a stiffness ratio k̄n/k̄s (2.6 for ν = 0.3)"),
        ];
        for (name, v, lo, hi, what) in ranges {
            if !(lo..=hi).contains(&v) {
                return Err(format!("parallel bond `{name}` = {v:e}: give {what} between {lo:e} and {hi:e}"));
            }
        }
        if !(self.phi.is_finite() && (0.0..PI / 2.0).contains(&self.phi)) {
            return Err(format!(
                "parallel bond `phi` = {}°: give a friction angle in [0°, 90°)",
                self.phi.to_degrees()
            ));
        }
        Ok(())
    }

    /// The bond between elements of radii `r1`, `r2`: its section and stiffnesses.
    #[inline(always)]
    pub fn section(&self, r1: f64, r2: f64) -> Section {
        let radius = self.lambda * r1.min(r2);
        let r2_ = radius * radius;
        let kn = self.e_star / (r1 + r2);
        Section {
            radius,
            area: PI * r2_,
            inertia: 0.25 * PI * r2_ * r2_,
            polar: 0.5 * PI * r2_ * r2_,
            kn,
            ks: kn / self.k_ratio,
        }
    }
}

/// A bond's cross-section and stiffnesses per area.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// R̄ (m).
    pub radius: f64,
    /// A = πR̄² (m²).
    pub area: f64,
    /// I = πR̄⁴/4 (m⁴), about a diameter.
    pub inertia: f64,
    /// J = πR̄⁴/2 (m⁴), polar.
    pub polar: f64,
    /// k̄n = Ē*/(R₁ + R₂) (Pa/m).
    pub kn: f64,
    /// k̄s = k̄n/k̄* (Pa/m).
    pub ks: f64,
}

/// Whether a bond carries load.
pub mod status {
    /// Broken (or never made): the pair is a plain linear contact.
    pub const BROKEN: u32 = 0;
    /// Intact.
    pub const INTACT: u32 = 1;
    /// Intact and made at the current positions: its first update takes no increment (the
    /// velocities of that step moved the elements to where the bond was made).
    pub const NEW: u32 = 2;
}

/// One bond's state, seen from its lower id (the canonical orientation): the forces and
/// moments on the higher id. Both rows of the pair hold the same value.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct BondState {
    /// Shear force on the higher id (N), in the bond's plane.
    pub shear: Vec3,
    /// Normal force (N), tension positive: the force on the higher id is −F̄n·n.
    pub normal: f64,
    /// Bending moment on the higher id (N·m), in the bond's plane.
    pub bending: Vec3,
    /// Twisting moment on the higher id about n (N·m).
    pub twist: f64,
    /// [`status`].
    pub status: u32,
}

impl BondState {
    pub fn intact(&self) -> bool {
        self.status != status::BROKEN
    }
}

/// The two ends of a bond, lower id first.
#[derive(Debug, Clone, Copy)]
pub struct Ends {
    pub pos: [Vec3; 2],
    pub vel: [Vec3; 2],
    pub ang_vel: [Vec3; 2],
    pub radius: [f64; 2],
}

/// What one update gives: the force and torque on each end, and the break, if any.
#[derive(Debug, Clone, Copy, Default)]
pub struct BondLoad {
    /// Force on the lower and the higher id (N): opposite.
    pub force: [Vec3; 2],
    /// Torque on the lower and the higher id (N·m).
    pub torque: [Vec3; 2],
    /// Set when the bond broke this step: how, and the elastic energy it held (J).
    pub broke: Option<(crate::physics::contact_law::BreakKind, f64)>,
}

/// The stresses at the bond's rim: σ̄ = F̄n/A + |M̄b|·R̄/I, τ̄ = |F̄s|/A + |M̄t|·R̄/J (Pa).
#[inline(always)]
pub fn stresses(st: &BondState, s: &Section) -> (f64, f64) {
    let sigma = st.normal / s.area + st.bending.norm() * s.radius / s.inertia;
    let tau = st.shear.norm() / s.area + st.twist.abs() * s.radius / s.polar;
    (sigma, tau)
}

/// Elastic energy the bond holds (J): F̄n²/(2k̄nA) + |F̄s|²/(2k̄sA) + M̄t²/(2k̄sJ) + |M̄b|²/(2k̄nI),
/// as (normal + bending, shear + twisting).
#[inline(always)]
pub fn energy(st: &BondState, s: &Section) -> (f64, f64) {
    let normal = st.normal * st.normal / (2.0 * s.kn * s.area) + st.bending.norm_squared() / (2.0 * s.kn * s.inertia);
    let shear = st.shear.norm_squared() / (2.0 * s.ks * s.area) + st.twist * st.twist / (2.0 * s.ks * s.polar);
    (normal, shear)
}

/// Advances one intact bond by a step of `dt`: rotates its shear force and bending moment with
/// the bond's axis, adds the increments of relative motion at the bond's centre (half way
/// across the gap), checks the strengths, and returns the loads on both ends. A bond that
/// breaks is left [`status::BROKEN`] with no load, and carries nothing this step.
#[inline(always)]
pub fn update(p: &ParallelBondParams, e: &Ends, st: &mut BondState, dt: f64) -> BondLoad {
    let d = e.pos[1] - e.pos[0];
    let dist = d.norm();
    let n = d / dist;
    let s = p.section(e.radius[0], e.radius[1]);
    // The bond's centre, half way across the gap, seen from each centre.
    let half_gap = 0.5 * (dist - e.radius[0] - e.radius[1]);
    let arm = [n * (e.radius[0] + half_gap), n * -(e.radius[1] + half_gap)];
    // The bond's plane turns with the axis: carry the shear force and bending moment along.
    st.shear = rotate_into_plane(st.shear, &n);
    st.bending = rotate_into_plane(st.bending, &n);
    if st.status == status::NEW {
        st.status = status::INTACT;
    } else {
        // Motion of the higher id relative to the lower at the bond's centre, and relative spin.
        let v = (e.vel[1] + e.ang_vel[1].cross(&arm[1])) - (e.vel[0] + e.ang_vel[0].cross(&arm[0]));
        let dd = v * dt;
        let dn = dd.dot(&n);
        let ds = dd - n * dn;
        let dth = (e.ang_vel[1] - e.ang_vel[0]) * dt;
        let dtw = dth.dot(&n);
        let db = dth - n * dtw;
        st.normal += s.kn * s.area * dn;
        st.shear -= ds * (s.ks * s.area);
        st.twist -= s.ks * s.polar * dtw;
        st.bending -= db * (s.kn * s.inertia);
    }
    let (sigma, tau) = stresses(st, &s);
    let strength = p.cohesion - st.normal / s.area * p.phi.tan();
    let kind = if sigma > p.sigma_c {
        Some(crate::physics::contact_law::BreakKind::Tension)
    } else if tau > strength {
        Some(crate::physics::contact_law::BreakKind::Shear)
    } else {
        None
    };
    if let Some(kind) = kind {
        let (en, es) = energy(st, &s);
        *st = BondState { status: status::BROKEN, ..BondState::default() };
        return BondLoad { broke: Some((kind, en + es)), ..BondLoad::default() };
    }
    let f = st.shear - n * st.normal;
    let m = n * st.twist + st.bending;
    BondLoad { force: [-f, f], torque: [arm[0].cross(&-f) - m, arm[1].cross(&f) + m], broke: None }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> ParallelBondParams {
        ParallelBondParams { lambda: 1.0, e_star: 1e8, k_ratio: 2.0, sigma_c: 1e6, cohesion: 1e6, phi: 0.5 }
    }

    // Values past the ranges left the numbers (k̄s = k̄n/1e-300; a section of 1e-300·r with
    // e_star 1e308), found by the host's robustness test; PFC's own values pass.
    #[test]
    fn parameters_whose_section_or_stiffness_leaves_the_numbers_are_refused_by_name() {
        assert_eq!(params().validate(), Ok(()));
        for (p, name) in [
            (ParallelBondParams { k_ratio: 1e-300, ..params() }, "k_ratio"),
            (ParallelBondParams { k_ratio: 1e3, ..params() }, "k_ratio"),
            (ParallelBondParams { lambda: 1e-300, ..params() }, "lambda"),
            (ParallelBondParams { e_star: 1e308, ..params() }, "e_star"),
        ] {
            let err = p.validate().unwrap_err();
            assert!(err.contains(&format!("`{name}`")) && err.contains("between"), "{err}");
        }
        let pfc = ParallelBondParams { lambda: 1.0, e_star: 4.8e10, k_ratio: 2.6, ..params() };
        assert_eq!(pfc.validate(), Ok(()));
    }

    #[test]
    fn the_section_of_two_unequal_spheres_is_the_smaller_ones_times_lambda() {
        let p = ParallelBondParams { lambda: 0.5, ..params() };
        let s = p.section(2e-3, 1e-3);
        assert_eq!(s.radius, 0.5e-3);
        assert!((s.area - PI * 0.25e-6).abs() < 1e-20);
        assert!((s.polar - 2.0 * s.inertia).abs() < 1e-30);
        assert!((s.kn - 1e8 / 3e-3).abs() < 1e-3 && (s.ks - s.kn / 2.0).abs() < 1e-3);
    }

    #[test]
    fn a_new_bond_takes_no_increment_on_its_first_step() {
        let e = Ends {
            pos: [Vec3::zeros(), Vec3::new(2e-3, 0.0, 0.0)],
            vel: [Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0)],
            ang_vel: [Vec3::zeros(); 2],
            radius: [1e-3; 2],
        };
        let mut st = BondState { status: status::NEW, ..Default::default() };
        let l = update(&params(), &e, &mut st, 1e-6);
        assert_eq!(st.normal, 0.0);
        assert_eq!(l.force, [Vec3::zeros(); 2]);
        update(&params(), &e, &mut st, 1e-6);
        let s = params().section(1e-3, 1e-3);
        assert!((st.normal - s.kn * s.area * 1e-6).abs() < 1e-12);
    }

    #[test]
    fn the_loads_on_the_two_ends_balance() {
        let e = Ends {
            pos: [Vec3::zeros(), Vec3::new(2e-3, 0.1e-3, 0.0)],
            vel: [Vec3::new(0.1, 0.0, 0.2), Vec3::new(0.3, -0.1, 0.0)],
            ang_vel: [Vec3::new(10.0, 0.0, 5.0), Vec3::new(-3.0, 2.0, 0.0)],
            radius: [1e-3, 1.2e-3],
        };
        let mut st = BondState { status: status::INTACT, ..Default::default() };
        let l = update(&params(), &e, &mut st, 1e-6);
        assert!(l.broke.is_none());
        assert_eq!(l.force[0], -l.force[1]);
        // Angular momentum about the origin: Σ x × F + T = 0.
        let total = e.pos[0].cross(&l.force[0]) + e.pos[1].cross(&l.force[1]) + l.torque[0] + l.torque[1];
        assert!(total.norm() < 1e-12 * (l.force[1].norm() * 2e-3 + l.torque[1].norm()), "{total:?}");
    }
}
