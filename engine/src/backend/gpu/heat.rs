//! The heat ledger on the device. The contact, wall and integration kernels book each
//! particle's heat by cause (the CPU's [`HeatLedger`](crate::state::particles::HeatLedger)
//! lanes) into `heat[i * lanes + slot]`, one slot per cause the plan can produce, so a scene
//! without walls or bonds pays for no wall-work or breakage lane. Each download adds the
//! device's sums to the model's f64 ledger; each upload starts them from zero.
//!
//! A slot is a compensated f32 pair (hi, lo) (`ledger_add` in common.wgsl): a step's heat
//! is ~1e-6 of what a run accumulates over 1e5–1e6 steps, and a plain f32 sum would round
//! most of it away.

use super::buffers::{read, DeviceLanes};
use super::device::GpuContext;
use crate::error::Result;
use crate::model::{Model, TangentialKind};
use crate::plan::StepPlan;

/// The ledger's causes, in the order of `HeatLedger::lanes_mut`, by their names in common.wgsl.
const CAUSES: [&str; 5] = ["HEAT_DAMPING", "HEAT_CONTACT_DAMPING", "HEAT_FRICTION", "HEAT_BREAKAGE", "HEAT_WALL_WORK"];

/// The slot of each cause on the device (`None`: the plan cannot produce that heat).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    slots: [Option<u32>; 5],
}

impl Layout {
    pub fn for_plan(plan: &StepPlan) -> Self {
        let shear_springs =
            plan.tangential == TangentialKind::Mindlin || plan.pair.iter().chain(&plan.wall).any(|p| p.ks > 0.0);
        let needed = [
            plan.damping > 0.0 || plan.local_damping > 0.0,
            plan.dashpot,
            // Sliding and opening contacts release shear-spring energy.
            shear_springs,
            plan.bonds,
            // A fixed wall does no work.
            plan.moving_walls + plan.servo_walls > 0,
        ];
        let mut next = 0;
        let slots = needed.map(|on| {
            on.then(|| {
                next += 1;
                next - 1
            })
        });
        Layout { slots }
    }

    /// Slots per particle.
    pub fn lanes(&self) -> usize {
        self.slots.iter().flatten().count()
    }

    /// The slots as the pipeline constants of common.wgsl (255: off).
    pub fn constants(&self) -> Vec<(&'static str, f64)> {
        let mut c = vec![("HEAT_LANES", self.lanes() as f64)];
        c.extend(CAUSES.iter().zip(self.slots).map(|(name, s)| (*name, f64::from(s.unwrap_or(255)))));
        c
    }

    /// Adds the heat the device booked since the upload to the model's ledger.
    pub fn fold(&self, ctx: &GpuContext, d: &DeviceLanes, m: &mut Model) -> Result<()> {
        let lanes = self.lanes();
        if lanes == 0 {
            return Ok(());
        }
        let sums: Vec<[f32; 2]> = read(ctx, &d.heat, d.n * lanes)?;
        for (lane, slot) in m.particles.heat.lanes_mut().into_iter().zip(self.slots) {
            let Some(slot) = slot else { continue };
            for (i, h) in lane.iter_mut().enumerate() {
                let [hi, lo] = sums[i * lanes + slot as usize];
                *h += f64::from(hi) + f64::from(lo);
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physics::contact_law::PairParams;

    #[test]
    fn slots_are_packed_in_ledger_order_and_only_for_causes_the_plan_has() {
        let mut p = StepPlan::build(&Model::new());
        p.dashpot = false;
        p.damping = 0.0;
        p.local_damping = 0.0;
        p.bonds = false;
        p.moving_walls = 0;
        p.servo_walls = 0;
        p.pair = vec![PairParams { ks: 4e5, ..Default::default() }];
        let l = Layout::for_plan(&p);
        assert_eq!(l.slots, [None, None, Some(0), None, None]);
        assert_eq!(l.lanes(), 1);
        p.dashpot = true;
        p.bonds = true;
        p.servo_walls = 1;
        let l = Layout::for_plan(&p);
        assert_eq!(l.slots, [None, Some(0), Some(1), Some(2), Some(3)]);
        let c = l.constants();
        assert_eq!(c[0], ("HEAT_LANES", 4.0));
        assert_eq!(c[1], ("HEAT_DAMPING", 255.0));
        assert_eq!(c[5], ("HEAT_WALL_WORK", 3.0));
    }
}
