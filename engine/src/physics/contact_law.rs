//! Contact laws between two elements, or an element and a rigid wall.
//!
//! MatDEM's linear elastic-brittle bonded model (paper 003, §2): normal force Kn·δ, tension
//! allowed while bonded up to the breaking force Kn·Xb; an incremental shear spring Ks
//! capped at Fs0 + μp·Fn while bonded and at μp·Fn once broken. Hertz (paper 000, eq. 7;
//! Johnson 1985 §4) replaces the compressive normal law; Mindlin's no-slip stiffness
//! 8·G*·a is the Hertz tangential option. A normal dashpot is set from a restitution.
//!
//! Sign conventions: `n` is the unit vector from this element towards the other body; the
//! overlap δ > 0 in compression; `v_rel` is the velocity of this element's contact point
//! relative to the other's. Every operation is odd in (n, v_rel, shear), so the two rows
//! of a pair compute exactly opposite forces and keep identical state.

use super::Vec3;
use crate::materials::Material;

/// Pair constants, combined once per pair of materials (springs in series, smaller strength).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PairParams {
    /// Normal spring (N/m).
    pub kn: f64,
    /// Shear spring (N/m).
    pub ks: f64,
    /// Bond breaking force in tension, Kn·Xb (N).
    pub breaking_force: f64,
    /// Initial shear resistance of the bond (N).
    pub fs0: f64,
    /// Friction coefficient.
    pub mu: f64,
    /// Effective Young's modulus E* (Pa).
    pub e_star: f64,
    /// Effective shear modulus G* (Pa), for Mindlin's tangential stiffness.
    pub g_star: f64,
    /// Linear dashpot: damping ratio ζ relative to critical.
    pub zeta: f64,
    /// Hertz dashpot: dimensionless α in c = α·√(m*·Kh)·δ^(1/4).
    pub alpha: f64,
}

/// Per-contact state carried from step to step, aligned with the neighbour rows.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PairState {
    /// Shear spring force on this element (N).
    pub shear: Vec3,
    /// Whether the pair is bonded (MatDEM's intact connection).
    pub bonded: bool,
    /// Normal dashpot force of the last step (N, positive against approach): its work over
    /// the half step after it is booked with the next step's heat (f32 fits the padding).
    #[serde(default)]
    pub dashpot: f32,
    /// How much of its material pair's strength (breaking force and Fs0) a bond has lost,
    /// in 1/65535 (MatDEM's bond strength rate, as `1 − weakened/65535`): 0 for a whole bond,
    /// set by joints (`Model::set_bond_strength`). Zero on every unbonded pair. A u16 keeps
    /// the state 32 bytes (it fits the padding after `bonded`), and 0 is the default.
    /// Checkpoints carry it beside the model (format 4), so the pair state's own encoding
    /// stays that of formats 2 and 3.
    #[serde(skip)]
    pub weakened: u16,
}

/// `weakened` of a bond with none of its strength left (never stored: such a bond is broken).
pub const WEAKENED_ALL: f64 = 65535.0;

impl PairState {
    /// The share of its material pair's strength this bond has: 1 unless weakened.
    #[inline(always)]
    pub fn strength(&self) -> f64 {
        1.0 - f64::from(self.weakened) / WEAKENED_ALL
    }

    /// `weakened` for a bond at `share` of its strength (0 < share ≤ 1), never all of it.
    pub fn weakened_for(share: f64) -> u16 {
        ((1.0 - share) * WEAKENED_ALL).round().clamp(0.0, WEAKENED_ALL - 1.0) as u16
    }
}

/// How a bond broke.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BreakKind {
    Tension,
    Shear,
}

/// Geometry and kinematics of one contact as seen from one element.
#[derive(Debug, Clone, Copy)]
pub struct ContactGeometry {
    pub n: Vec3,
    pub overlap: f64,
    pub v_rel: Vec3,
    pub r_star: f64,
    pub m_star: f64,
}

/// What one contact does to this element in one step.
#[derive(Debug, Clone, Copy, Default)]
pub struct ContactResult {
    /// Total force on this element (N): `shear − n·normal_force`.
    pub force: Vec3,
    /// Normal force, elastic and dashpot, positive in compression (N); 0 once the bond broke
    /// in tension.
    pub normal_force: f64,
    /// Tangential force on this element (N), for torque: the shear spring, plus the
    /// tangential dashpot of a damped law.
    pub shear: Vec3,
    /// The tangential dashpot's force on this element (N); zero unless `T::DAMPED`.
    pub tangential_dashpot: Vec3,
    pub broke: Option<BreakKind>,
    /// Energy this contact turned into heat during the step, split by cause (J, whole pair).
    pub heat_damping: f64,
    pub heat_friction: f64,
    pub heat_breakage: f64,
    /// Normal stiffness at this overlap (N/m), for servo gains and time-step checks.
    pub stiffness: f64,
    /// Normal dashpot coefficient at this overlap (N·s/m); zero without a dashpot. A servo
    /// wall's gain needs it beside the stiffness: moving the wall by Δx in one step adds
    /// c·Δx/dt to the force at once.
    pub damping: f64,
}

/// The compressive normal law of a scene.
pub trait NormalLaw: Copy + Send + Sync + 'static {
    /// The law's name in scripts and plans (`d.normal = "hertz"`).
    const NAME: &'static str;
    /// What the guard calls its tangent stiffness.
    const STIFFNESS: &'static str;
    /// The power of λ by which a contact's force grows when a model is scaled by λ with its
    /// materials kept (`scaling.rs`): a linear spring's λ, Hertz's λ² (√R·δ^(3/2)).
    const FORCE_POWER: i32;
    /// The stiffness an element of radius `r` of `material` meets in its stiffest likely
    /// contact, a rigid wall (what the standard step is set from).
    fn element_stiffness(material: &Material, r: f64) -> f64;
    /// The switches of common.wgsl's contact law that select it on the GPU (pipeline
    /// constants; `shaders::constants`).
    const GPU: [(&'static str, bool); 1];
    /// Elastic normal force for overlap δ > 0.
    fn force(p: &PairParams, r_star: f64, overlap: f64) -> f64;
    /// Tangent stiffness dF/dδ at overlap δ > 0.
    fn stiffness(p: &PairParams, r_star: f64, overlap: f64) -> f64;
    /// Dashpot coefficient c (N·s/m) at overlap δ > 0.
    fn dashpot(p: &PairParams, r_star: f64, m_star: f64, overlap: f64) -> f64;
    /// Elastic energy stored at overlap δ > 0 (J).
    fn energy(p: &PairParams, r_star: f64, overlap: f64) -> f64;
}

/// Linear spring Kn·δ (MatDEM's default).
#[derive(Debug, Clone, Copy)]
pub struct Linear;

/// Hertz: F = (4/3)·E*·√R*·δ^(3/2).
#[derive(Debug, Clone, Copy)]
pub struct Hertz;

impl NormalLaw for Linear {
    const NAME: &'static str = "linear";
    const STIFFNESS: &'static str = "linear normal spring";
    const FORCE_POWER: i32 = 1;
    const GPU: [(&'static str, bool); 1] = [("NORMAL_HERTZ", false)];
    #[inline(always)]
    fn element_stiffness(material: &Material, _r: f64) -> f64 {
        2.0 * material.kn
    }
    #[inline(always)]
    fn force(p: &PairParams, _r: f64, overlap: f64) -> f64 {
        p.kn * overlap
    }
    #[inline(always)]
    fn stiffness(p: &PairParams, _r: f64, _overlap: f64) -> f64 {
        p.kn
    }
    #[inline(always)]
    fn dashpot(p: &PairParams, _r: f64, m_star: f64, _overlap: f64) -> f64 {
        2.0 * p.zeta * (p.kn * m_star).sqrt()
    }
    #[inline(always)]
    fn energy(p: &PairParams, _r: f64, overlap: f64) -> f64 {
        0.5 * p.kn * overlap * overlap
    }
}

/// Hertz's constant Kh = (4/3)·E*·√R*, so that F = Kh·δ^(3/2).
#[inline(always)]
pub fn hertz_constant(e_star: f64, r_star: f64) -> f64 {
    4.0 / 3.0 * e_star * r_star.sqrt()
}

impl NormalLaw for Hertz {
    const NAME: &'static str = "hertz";
    const STIFFNESS: &'static str = "hertz normal stiffness";
    const FORCE_POWER: i32 = 2;
    const GPU: [(&'static str, bool); 1] = [("NORMAL_HERTZ", true)];
    /// The tangent stiffness against a wall at an overlap of 5 % of r.
    #[inline(always)]
    fn element_stiffness(material: &Material, r: f64) -> f64 {
        let e_star = material.young / (1.0 - material.poisson * material.poisson);
        2.0 * e_star * r * 0.05f64.sqrt()
    }
    #[inline(always)]
    fn force(p: &PairParams, r_star: f64, overlap: f64) -> f64 {
        hertz_constant(p.e_star, r_star) * overlap * overlap.sqrt()
    }
    #[inline(always)]
    fn stiffness(p: &PairParams, r_star: f64, overlap: f64) -> f64 {
        1.5 * hertz_constant(p.e_star, r_star) * overlap.sqrt()
    }
    #[inline(always)]
    fn dashpot(p: &PairParams, r_star: f64, m_star: f64, overlap: f64) -> f64 {
        // α·√(m*·Kh)·δ^¼ as α·√(m*·Kh·√δ): one square root on top of the force's √δ.
        p.alpha * (m_star * hertz_constant(p.e_star, r_star) * overlap.sqrt()).sqrt()
    }
    #[inline(always)]
    fn energy(p: &PairParams, r_star: f64, overlap: f64) -> f64 {
        0.4 * hertz_constant(p.e_star, r_star) * overlap * overlap * overlap.sqrt()
    }
}

/// The shear spring's stiffness, and whether a tangential dashpot acts beside it.
pub trait TangentialLaw: Copy + Send + Sync + 'static {
    /// The law's name in scripts (`d.tangential = "mindlin"`).
    const NAME: &'static str;
    /// How a plan describes it.
    const DESCRIPTION: &'static str;
    /// What the guard calls its stiffness.
    const STIFFNESS: &'static str;
    /// The power of λ by which the shear force grows when a model is scaled by λ with its
    /// materials kept (as [`NormalLaw::FORCE_POWER`]): Ks's λ, Mindlin's λ².
    const FORCE_POWER: i32;
    /// The switches of common.wgsl's contact law that select it on the GPU (as
    /// [`NormalLaw::GPU`]).
    const GPU: [(&'static str, bool); 2];
    /// A tangential dashpot acts in parallel with the spring (a compile-time constant, so a
    /// law without one carries no branch for it).
    const DAMPED: bool = false;
    fn stiffness(p: &PairParams, r_star: f64, overlap: f64) -> f64;
    /// Tangential dashpot coefficient c_t (N·s/m) for the spring's stiffness `kt`; read only
    /// when [`DAMPED`](Self::DAMPED).
    #[inline(always)]
    fn dashpot(_p: &PairParams, _m_star: f64, _kt: f64) -> f64 {
        0.0
    }
}

/// A constant shear spring Ks (MatDEM).
#[derive(Debug, Clone, Copy)]
pub struct LinearShear;

/// Mindlin's no-slip stiffness kt = 8·G*·√(R*·δ) (as in LIGGGHTS' `tangential history`).
#[derive(Debug, Clone, Copy)]
pub struct MindlinShear;

/// Mindlin's stiffness with LIGGGHTS' `tangential_damping on`: a dashpot
/// c_t = 2·√(5/6)·|β|·√(S_t·m*) in parallel, with S_t = 8·G*·√(R*·δ) the Mindlin stiffness
/// and β = ln e/√(ln²e + π²) from the restitution e of the normal dashpot (|β| is the linear
/// damping ratio ζ of `restitution::linear_damping_ratio`, `PairParams::zeta`). The spring
/// and the dashpot are capped at μ·Fn together.
#[derive(Debug, Clone, Copy)]
pub struct MindlinDampedShear;

impl TangentialLaw for LinearShear {
    const NAME: &'static str = "linear";
    const DESCRIPTION: &'static str = "shear spring Ks";
    const STIFFNESS: &'static str = "shear spring";
    const FORCE_POWER: i32 = 1;
    const GPU: [(&'static str, bool); 2] = [("MINDLIN", false), ("TANGENTIAL_DASHPOT", false)];
    #[inline(always)]
    fn stiffness(p: &PairParams, _r: f64, _overlap: f64) -> f64 {
        p.ks
    }
}

impl TangentialLaw for MindlinShear {
    const NAME: &'static str = "mindlin";
    const DESCRIPTION: &'static str = "mindlin shear spring";
    const STIFFNESS: &'static str = "mindlin shear stiffness";
    const FORCE_POWER: i32 = 2;
    const GPU: [(&'static str, bool); 2] = [("MINDLIN", true), ("TANGENTIAL_DASHPOT", false)];
    #[inline(always)]
    fn stiffness(p: &PairParams, r_star: f64, overlap: f64) -> f64 {
        // √R*·√δ rather than √(R*·δ): Hertz's force has taken both roots already.
        8.0 * p.g_star * r_star.sqrt() * overlap.max(0.0).sqrt()
    }
}

/// 2·√(5/6), LIGGGHTS' factor between the tangential dashpot and the critical one.
pub const TANGENTIAL_DASHPOT_FACTOR: f64 = 1.825_741_858_350_553_8;

impl TangentialLaw for MindlinDampedShear {
    const NAME: &'static str = "mindlin_damped";
    const DESCRIPTION: &'static str = "mindlin shear spring + tangential dashpot";
    const STIFFNESS: &'static str = "mindlin shear stiffness";
    const FORCE_POWER: i32 = 2;
    const GPU: [(&'static str, bool); 2] = [("MINDLIN", true), ("TANGENTIAL_DASHPOT", true)];
    const DAMPED: bool = true;
    #[inline(always)]
    fn stiffness(p: &PairParams, r_star: f64, overlap: f64) -> f64 {
        MindlinShear::stiffness(p, r_star, overlap)
    }
    #[inline(always)]
    fn dashpot(p: &PairParams, m_star: f64, kt: f64) -> f64 {
        TANGENTIAL_DASHPOT_FACTOR * p.zeta * (kt * m_star).sqrt()
    }
}

/// One contact for one step: updates `state` (shear spring, bond) and returns the force on
/// this element. Call only for bonded pairs or pairs with δ > 0.
///
/// `DASHPOT` folds the normal dashpot away at compile time when no material asks for one.
#[inline(always)]
pub fn contact<N: NormalLaw, T: TangentialLaw, const DASHPOT: bool>(
    g: &ContactGeometry,
    p: &PairParams,
    state: &mut PairState,
    dt: f64,
) -> ContactResult {
    let mut out = ContactResult::default();
    let overlap = g.overlap;
    let touching = overlap > 0.0;
    // The laws read the overlap clamped at zero, the very value while touching, so that the
    // tangential law's √max(δ, 0) is the normal law's √δ, taken once.
    let compressed = overlap.max(0.0);
    // Elastic normal force: the law in compression, the bond's linear spring in tension.
    let (fn_el, kn) = if touching {
        (N::force(p, g.r_star, compressed), N::stiffness(p, g.r_star, compressed))
    } else {
        (p.kn * overlap, p.kn)
    };
    out.stiffness = kn;
    // Normal relative velocity, > 0 while the overlap grows.
    let vn = g.v_rel.dot(&g.n);
    // Shear spring: carry the old force into the current tangent plane, then add Ks·Δu_t.
    let kt = T::stiffness(p, g.r_star, compressed);
    let vt = g.v_rel - g.n * vn;
    let s_prev = rotate_into_plane(state.shear, &g.n);
    let mut s = s_prev - vt * (kt * dt);
    // A weakened bond (a joint) breaks at its share of the pair's strength. The share is read
    // inside the bonded branches only: most pairs of most scenes are unbonded and should not
    // pay for its conversion and divide (they did: ~1 % of the standard scene's instructions).
    if state.bonded && fn_el < -p.breaking_force * state.strength() {
        // Broken in tension: the stretched bond's energy becomes heat; no contact remains.
        out.heat_breakage = bond_tension_release(p, overlap, vn, dt) + released(s, Vec3::zeros(), s_prev, kt);
        out.heat_damping = dashpot_release(state, vn, dt);
        out.broke = Some(BreakKind::Tension);
        state.bonded = false;
        state.weakened = 0;
        state.shear = Vec3::zeros();
        return out;
    }
    let mut fn_total = fn_el;
    if DASHPOT && touching {
        let c = N::dashpot(p, g.r_star, g.m_star, compressed);
        out.damping = c;
        let f_dash = c * vn;
        fn_total += f_dash;
        // The dashpot force works over the step at the mean of its last and present values
        // (the trapezoid rule): booking c·vn²·dt instead counts the force of the first
        // touching step over a whole step although it acted from the middle of it, about
        // ζ·ω·dt too much heat per impact.
        out.heat_damping = 0.5 * (f64::from(state.dashpot) + f_dash) * vn * dt;
        state.dashpot = f_dash as f32;
    } else if DASHPOT {
        out.heat_damping = dashpot_release(state, vn, dt);
    }

    // Tangential dashpot (a law that has one, and only where a material asks for damping: with
    // e = 1 its coefficient is 0). Its heat is c_t·|v_t|²·dt, the force of this step over the
    // step (not the trapezoid of the normal dashpot, which would need last step's vector in
    // the pair state: the difference telescopes to ¼·c_t·dt·Δ|v_t|², and c_t ∝ δ^¼ vanishes
    // where a contact opens or closes).
    let damped = T::DAMPED && DASHPOT && touching;
    let f_td = if damped { vt * -T::dashpot(p, g.m_star, kt) } else { Vec3::zeros() };
    let heat_td = if damped { -f_td.dot(&vt) * dt } else { 0.0 };
    out.heat_damping += heat_td;
    // Spring and dashpot are capped together (LIGGGHTS, LAMMPS gran/hertz/history).
    let total = if T::DAMPED { s + f_td } else { s };

    let mut limit =
        if state.bonded { (p.fs0 * state.strength() + p.mu * fn_el).max(0.0) } else { p.mu * fn_el.max(0.0) };
    let s2 = total.norm_squared();
    // The dashpot force the element feels: clipped to the cap when the contact slides.
    let mut f_felt = f_td;
    if s2 > limit * limit {
        if state.bonded {
            // The bond fails in shear; from now on only friction holds.
            state.bonded = false;
            state.weakened = 0;
            out.broke = Some(BreakKind::Shear);
            limit = p.mu * fn_el.max(0.0);
            if !touching {
                out.heat_breakage = bond_tension_release(p, overlap, vn, dt);
                fn_total = 0.0;
            }
        }
        if s2 > limit * limit {
            let mag = s2.sqrt();
            // With a dashpot the total is scaled to the cap and the spring keeps the rest
            // (LIGGGHTS, LAMMPS). A dashpot that alone exceeds the cap is clipped to it first:
            // otherwise the spring would be wound against the slip by |f_td| − μ·Fn, energy no
            // force supplied (with c_t·v ≫ μ·Fn, as in the first steps of a fast slide).
            let capped = if T::DAMPED {
                let d2 = f_td.norm_squared();
                f_felt = if d2 > limit * limit { f_td * (limit / d2.sqrt()) } else { f_td };
                total * (limit / mag) - f_felt
            } else {
                s * (limit / mag)
            };
            if out.broke.is_some() {
                // The failed bond's shear energy above the friction cap is released.
                out.heat_breakage += released(s, capped, s_prev, kt);
            } else if T::DAMPED {
                // Sliding, the contact dissipates μ·Fn·slip whatever the split between spring
                // and dashpot: all of it is friction heat, the spring's release and the felt
                // dashpot's work together (the sum closes the account; a negative remainder,
                // from a turning contact, stays with damping).
                let slip = released_signed(s, capped, s_prev, kt) - f_felt.dot(&vt) * dt;
                out.heat_friction = slip.max(0.0);
                out.heat_damping += slip.min(0.0) - heat_td;
            } else {
                // Sliding: the friction force works over the slip (|s| − limit)/kt, taken at
                // its mean over the step, (prev + capped)/2 (`released`; in steady sliding
                // limit·slip). The drop in stored energy ½(|s|² − limit²)/kt would also count
                // ½(|s| − limit)²/kt that no force did: with μ = 0, heat from nothing.
                out.heat_friction = released(s, capped, s_prev, kt);
            }
            s = capped;
        }
    }
    state.shear = s;
    out.tangential_dashpot = f_felt;
    // The tangential force the element feels (its torque's lever acts on it): spring + dashpot.
    let shear = if T::DAMPED { s + f_felt } else { s };
    out.shear = shear;
    out.force = shear - g.n * fn_total;
    out.normal_force = fn_total;
    out
}

/// Heat of the dashpot force of the last touching step over the step in which the contact
/// opened (the second half of its trapezoid), for the normal relative velocity `vn` of this
/// step; clears it.
#[inline(always)]
fn dashpot_release(state: &mut PairState, vn: f64, dt: f64) -> f64 {
    let f = f64::from(state.dashpot);
    state.dashpot = 0.0;
    0.5 * f * vn * dt
}

/// An unbonded contact that is open this step (no overlap): backends call this instead of
/// [`contact`], with `n` towards the other body and the contact points' relative velocity
/// `v_rel`, as for a closed contact. If the contact was closed until now, its shear spring
/// lets go and the energy it held is dissipated (`released`: booked as friction heat, or it
/// would vanish from the account), and its last dashpot force still worked over this step.
/// Returns (friction heat, damping heat) for the whole pair and clears the state.
#[inline(always)]
pub fn contact_opened<T: TangentialLaw>(
    p: &PairParams,
    r_star: f64,
    state: &mut PairState,
    n: &Vec3,
    v_rel: Vec3,
    dt: f64,
) -> (f64, f64) {
    let vn = v_rel.dot(n);
    let kt = T::stiffness(p, r_star, 0.0);
    let s_prev = rotate_into_plane(state.shear, n);
    let trial = s_prev - (v_rel - n * vn) * (kt * dt);
    state.shear = Vec3::zeros();
    (released(trial, Vec3::zeros(), s_prev, kt), dashpot_release(state, vn, dt))
}

/// Energy a spring of stiffness `k` releases when its force drops, within one step, from
/// the elastic value `trial` to `kept`, having carried `prev` during the step before:
/// ½·(trial − kept)·(kept + prev)/k.
///
/// This is the release that keeps the leapfrog energy account (kinetic energy of the mean
/// velocity at the integer step plus the springs' energy there) continuous: the particles
/// felt `prev` over the last step and feel `kept` from now on. ½·(|trial|² − |kept|²)/k,
/// the drop in stored energy alone, books an extra ½·(trial − kept)·(trial − prev)/k, about
/// F·v·dt/2 per event, that nothing dissipated: when a bond stretches by a good part of its
/// breaking displacement per step, a few per cent of the breakage heat appears from nowhere.
#[inline(always)]
fn released(trial: Vec3, kept: Vec3, prev: Vec3, k: f64) -> f64 {
    released_signed(trial, kept, prev, k).max(0.0)
}

/// [`released`] without the floor at zero: negative when the spring is left holding more than
/// the slip paid for (a spring rescaled against a dashpot).
#[inline(always)]
fn released_signed(trial: Vec3, kept: Vec3, prev: Vec3, k: f64) -> f64 {
    if k > 0.0 {
        0.5 * (trial - kept).dot(&(kept + prev)) / k
    } else {
        0.0
    }
}

/// Energy a bond stretched in tension (δ < 0) releases when it breaks and its normal force
/// drops to zero: `released` for the normal spring, whose overlap a step earlier was
/// δ − vn·dt.
#[inline(always)]
fn bond_tension_release(p: &PairParams, overlap: f64, vn: f64, dt: f64) -> f64 {
    if overlap < 0.0 {
        (0.5 * p.kn * overlap * (overlap - vn * dt)).max(0.0)
    } else {
        0.0
    }
}

/// Elastic energy of a shear spring carrying force `s` (J).
#[inline(always)]
pub fn shear_energy(s: Vec3, kt: f64) -> f64 {
    if kt > 0.0 {
        0.5 * s.norm_squared() / kt
    } else {
        0.0
    }
}

/// Projects a shear force onto the plane normal to `n`, keeping its magnitude, so that a
/// rotating contact carries its spring force along instead of losing or creating energy.
#[inline(always)]
pub fn rotate_into_plane(s: Vec3, n: &Vec3) -> Vec3 {
    let s2 = s.norm_squared();
    if s2 == 0.0 {
        return s;
    }
    let p = s - n * n.dot(&s);
    let p2 = p.norm_squared();
    if p2 == 0.0 {
        return Vec3::zeros();
    }
    p * (s2 / p2).sqrt()
}

/// Elastic energy stored in a contact at this overlap, for energy bookkeeping (J).
#[inline(always)]
pub fn normal_energy<N: NormalLaw>(p: &PairParams, r_star: f64, overlap: f64, bonded: bool) -> f64 {
    if overlap > 0.0 {
        N::energy(p, r_star, overlap)
    } else if bonded {
        0.5 * p.kn * overlap * overlap
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> PairParams {
        PairParams {
            kn: 1e6,
            ks: 4e5,
            breaking_force: 1e6 * 1e-5,
            fs0: 2.0,
            mu: 0.5,
            e_star: 1e9,
            g_star: 4e8,
            zeta: 0.0,
            alpha: 0.0,
        }
    }

    fn geometry(overlap: f64, v_rel: Vec3) -> ContactGeometry {
        ContactGeometry { n: Vec3::x(), overlap, v_rel, r_star: 0.5e-3, m_star: 1e-3 }
    }

    #[test]
    fn hertz_force_is_four_thirds_e_sqrt_r_delta_three_halves() {
        let p = params();
        let f = Hertz::force(&p, 0.01, 1e-4);
        let expected = 4.0 / 3.0 * 1e9 * 0.1 * 1e-6;
        assert!(((f - expected) / expected).abs() < 1e-14);
        // Energy is the integral of the force: check by the trapezoid rule.
        let n = 10_000;
        let mut w = 0.0;
        for k in 0..n {
            let (a, b) = (1e-4 * k as f64 / n as f64, 1e-4 * (k + 1) as f64 / n as f64);
            w += 0.5 * (Hertz::force(&p, 0.01, a) + Hertz::force(&p, 0.01, b)) * (b - a);
        }
        assert!((w - Hertz::energy(&p, 0.01, 1e-4)).abs() / w < 1e-6);
    }

    #[test]
    fn hertz_dashpot_is_alpha_sqrt_m_kh_times_quarter_power_of_overlap() {
        // The law takes α·√(m*·Kh·√δ) to save a root: the same as the textbook form.
        let p = PairParams { alpha: 0.37, ..params() };
        for &(r, m, d) in &[(0.5e-3_f64, 1e-3_f64, 1e-6_f64), (2e-2, 3.0, 4e-4), (1e-6, 1e-15, 1e-9)] {
            let kh = hertz_constant(p.e_star, r);
            let expected = 0.37 * (m * kh).sqrt() * d.powf(0.25);
            let c = Hertz::dashpot(&p, r, m, d);
            assert!(((c - expected) / expected).abs() < 1e-14, "{c} vs {expected}");
        }
    }

    #[test]
    fn mindlin_stiffness_is_eight_g_sqrt_r_delta_and_zero_in_tension() {
        let p = params();
        for &(r, d) in &[(0.5e-3_f64, 1e-6_f64), (2e-2, 4e-4), (1e-6, 1e-9)] {
            let expected = 8.0 * p.g_star * (r * d).sqrt();
            let k = MindlinShear::stiffness(&p, r, d);
            assert!(((k - expected) / expected).abs() < 1e-14, "{k} vs {expected}");
        }
        assert_eq!(MindlinShear::stiffness(&p, 1e-3, -1e-6), 0.0);
    }

    #[test]
    fn tangential_dashpot_is_liggghts_two_root_five_sixths_beta_root_st_m() {
        // LIGGGHTS' gammat = −2·√(5/6)·β·√(S_t·m*), β = ln e/√(ln²e + π²).
        let e: f64 = 0.4;
        let beta = e.ln() / (e.ln().powi(2) + std::f64::consts::PI.powi(2)).sqrt();
        let p = PairParams { zeta: crate::physics::restitution::linear_damping_ratio(e), ..params() };
        let (r, m, d) = (2e-3_f64, 5e-4_f64, 3e-6_f64);
        let st = 8.0 * p.g_star * (r * d).sqrt();
        let kt = MindlinDampedShear::stiffness(&p, r, d);
        let expected = -2.0 * (5.0f64 / 6.0).sqrt() * beta * (st * m).sqrt();
        let c = MindlinDampedShear::dashpot(&p, m, kt);
        assert!(((c - expected) / expected).abs() < 1e-12, "{c} vs {expected}");
        assert_eq!(MindlinShear::dashpot(&p, m, kt), 0.0);
    }

    #[test]
    fn damped_shear_total_is_capped_at_mu_fn_and_odd_between_rows() {
        let p = PairParams { zeta: 0.3, mu: 0.2, ..params() };
        let g = ContactGeometry {
            n: Vec3::new(0.6, 0.0, 0.8),
            overlap: 3e-6,
            v_rel: Vec3::new(0.1, -7.0, 0.05),
            r_star: 1e-3,
            m_star: 1e-3,
        };
        let g2 = ContactGeometry { n: -g.n, v_rel: -g.v_rel, ..g };
        let (mut a, mut b) = (PairState::default(), PairState::default());
        for _ in 0..20 {
            let ra = contact::<Hertz, MindlinDampedShear, true>(&g, &p, &mut a, 1e-6);
            let rb = contact::<Hertz, MindlinDampedShear, true>(&g2, &p, &mut b, 1e-6);
            assert_eq!(ra.force, -rb.force);
            assert_eq!(a.shear, -b.shear);
            let cap = p.mu * Hertz::force(&p, g.r_star, g.overlap);
            assert!((ra.shear.norm() - cap).abs() < 1e-12 * cap, "{} vs μFn {cap}", ra.shear.norm());
            assert!(ra.heat_friction > 0.0 && ra.heat_damping >= 0.0);
        }
    }

    #[test]
    fn bonded_pair_breaks_in_tension_at_kn_xb() {
        let p = params();
        let mut s = PairState { shear: Vec3::zeros(), bonded: true, ..Default::default() };
        // Just below the breaking displacement the bond holds and pulls.
        let r = contact::<Linear, LinearShear, false>(&geometry(-0.999e-5, Vec3::zeros()), &p, &mut s, 1e-6);
        assert!(r.broke.is_none() && s.bonded);
        assert!((r.force.x - 9.99).abs() < 1e-9, "tension pulls towards the other: {:?}", r.force);
        let r = contact::<Linear, LinearShear, false>(&geometry(-1.001e-5, Vec3::zeros()), &p, &mut s, 1e-6);
        assert_eq!(r.broke, Some(BreakKind::Tension));
        assert!(!s.bonded && r.force == Vec3::zeros());
    }

    #[test]
    fn shear_spring_slips_at_fs0_plus_mu_fn_while_bonded_then_mu_fn_once_broken() {
        let p = params();
        let overlap = 1e-5; // Fn = 10 N
        let mut s = PairState { shear: Vec3::zeros(), bonded: true, ..Default::default() };
        let dt = 1e-6;
        let v = Vec3::new(0.0, 1.0, 0.0); // 1 µm of sliding per step → 0.4 N per step
        let mut broke_at = None;
        for k in 0..100 {
            let r = contact::<Linear, LinearShear, false>(&geometry(overlap, v), &p, &mut s, dt);
            if r.broke.is_some() {
                broke_at = Some((k, r));
                break;
            }
            assert!(r.shear.norm() <= 2.0 + 0.5 * 10.0 + 1e-12);
        }
        let (k, r) = broke_at.expect("bond must fail in shear");
        assert_eq!(r.broke, Some(BreakKind::Shear));
        // 7 N = Fs0 + μ·Fn is reached after 17.5 increments of 0.4 N.
        assert_eq!(k, 17);
        assert!((r.shear.norm() - 5.0).abs() < 1e-12, "after breaking the cap is μ·Fn");
        let r = contact::<Linear, LinearShear, false>(&geometry(overlap, v), &p, &mut s, dt);
        assert!((r.shear.norm() - 5.0).abs() < 1e-12 && r.heat_friction > 0.0);
    }

    #[test]
    fn rotate_into_plane_keeps_magnitude_and_is_odd() {
        let s = Vec3::new(0.3, 1.0, -0.2);
        let n = Vec3::new(1.0, 0.2, 0.1).normalize();
        let r = rotate_into_plane(s, &n);
        assert!((r.norm() - s.norm()).abs() < 1e-15);
        assert!(r.dot(&n).abs() < 1e-15);
        assert_eq!(rotate_into_plane(-s, &-n), -r);
    }

    #[test]
    fn pair_rows_compute_exactly_opposite_forces() {
        let p = PairParams { zeta: 0.3, ..params() };
        let g = ContactGeometry {
            n: Vec3::new(0.6, 0.0, 0.8),
            overlap: 3e-6,
            v_rel: Vec3::new(0.1, -0.7, 0.05),
            r_star: 1e-3,
            m_star: 1e-3,
        };
        let g2 = ContactGeometry { n: -g.n, v_rel: -g.v_rel, ..g };
        let mut a = PairState { shear: Vec3::new(0.0, 0.2, 0.0), bonded: true, ..Default::default() };
        let mut b = PairState { shear: -a.shear, bonded: true, ..Default::default() };
        for _ in 0..50 {
            let ra = contact::<Hertz, MindlinShear, true>(&g, &p, &mut a, 1e-6);
            let rb = contact::<Hertz, MindlinShear, true>(&g2, &p, &mut b, 1e-6);
            assert_eq!(ra.force, -rb.force);
            assert_eq!(a.shear, -b.shear);
            assert_eq!(a.bonded, b.bonded);
        }
    }
}
