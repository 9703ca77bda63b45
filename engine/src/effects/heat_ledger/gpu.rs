//! The heat ledger on the device. The contact, wall and integration kernels book each
//! particle's heat by cause (the CPU's [`HeatLedger`](crate::state::particles::HeatLedger)
//! lanes) into `heat[i * lanes + slot]`, one slot per cause the plan can produce, so a scene
//! without walls or bonds pays for no wall-work or breakage lane. Each download adds the
//! device's sums to the model's f64 ledger; each upload starts them from zero.
//!
//! A slot is a compensated f32 pair (hi, lo) (`ledger_add` in heat_ledger.wgsl): a step's heat
//! is ~1e-6 of what a run accumulates over 1e5–1e6 steps, and a plain f32 sum would round
//! most of it away.

use crate::backend::gpu::buffers::{read, DeviceLanes};
use crate::backend::gpu::device::GpuContext;
use crate::error::Result;
use crate::model::Model;
use crate::plan::StepPlan;

/// The ledger's causes, in the order of `HeatLedger::lanes_mut`, by their names in heat_ledger.wgsl.
const CAUSES: [&str; 5] = ["HEAT_DAMPING", "HEAT_CONTACT_DAMPING", "HEAT_FRICTION", "HEAT_BREAKAGE", "HEAT_WALL_WORK"];

/// The slot of each cause on the device (`None`: the plan cannot produce that heat).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    slots: [Option<u32>; 5],
}

impl Layout {
    pub fn for_plan(plan: &StepPlan) -> Self {
        let needed = plan.heat.flags();
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

    /// The slots as the pipeline constants of heat_ledger.wgsl (255: off).
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
        m.particles.heat.fit(&plan_causes(self), d.n);
        for (lane, slot) in m.particles.heat.lanes_mut().into_iter().zip(self.slots) {
            let Some(slot) = slot else { continue };
            for (i, h) in lane.iter_mut().enumerate() {
                // Cause by cause, as ledger_index in heat_ledger.wgsl lays them.
                let [hi, lo] = sums[slot as usize * d.n + i];
                *h += f64::from(hi) + f64::from(lo);
            }
        }
        Ok(())
    }
}

/// The causes a layout books, for fitting the model's ledger to it.
fn plan_causes(l: &Layout) -> crate::state::particles::HeatCauses {
    let [damping, contact_damping, friction, breakage, wall_work] = l.slots.map(|s| s.is_some());
    crate::state::particles::HeatCauses { damping, contact_damping, friction, breakage, wall_work }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::state::particles::HeatCauses;

    #[test]
    fn slots_are_packed_in_ledger_order_and_only_for_causes_the_plan_has() {
        let mut p = StepPlan::build(&Model::new());
        p.heat = HeatCauses { friction: true, ..Default::default() };
        let l = Layout::for_plan(&p);
        assert_eq!(l.slots, [None, None, Some(0), None, None]);
        assert_eq!(l.lanes(), 1);
        p.heat = HeatCauses { contact_damping: true, friction: true, breakage: true, wall_work: true, damping: false };
        let l = Layout::for_plan(&p);
        assert_eq!(l.slots, [None, Some(0), Some(1), Some(2), Some(3)]);
        let c = l.constants();
        assert_eq!(c[0], ("HEAT_LANES", 4.0));
        assert_eq!(c[1], ("HEAT_DAMPING", 255.0));
        assert_eq!(c[5], ("HEAT_WALL_WORK", 3.0));
    }
}
