//! The plan in words: the step's stages with their parameters, the lanes per particle and the
//! effects not simulated, as `d.plan()` and `matdem-rs plan` print them.

use super::{Role, StepPlan, REGISTRY};
use std::fmt;

/// A plan in words for one backend ([`StepPlan::on`]): the bytes the pore network takes are the
/// backend's (the CPU's f64 lanes or the GPU's f32 buffers).
pub struct PlanText<'a> {
    plan: &'a StepPlan,
    gpu: bool,
}

impl StepPlan {
    /// The plan in words as the GPU backend (`gpu`) or the CPU backend runs it; `Display` is
    /// the CPU's.
    pub fn on(&self, gpu: bool) -> PlanText<'_> {
        PlanText { plan: self, gpu }
    }
}

impl fmt::Display for StepPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.on(false).fmt(f)
    }
}

impl fmt::Display for PlanText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.plan.write_text(f, self.gpu)
    }
}

impl StepPlan {
    /// The words of the stages of `role` this plan runs, in step order (each effect's own,
    /// from its registry row).
    fn words_of(&self, role: Role) -> impl Iterator<Item = String> + '_ {
        self.runs(role).filter_map(|s| (s.entry().words)(self))
    }

    fn write_text(&self, f: &mut fmt::Formatter<'_>, gpu: bool) -> fmt::Result {
        let mut stages = Vec::new();
        if self.walls > 0 {
            stages.push(format!(
                "walls({} fixed, {} moving, {} servo)",
                self.walls - self.moving_walls - self.servo_walls,
                self.moving_walls,
                self.servo_walls
            ));
        }
        stages.push(if self.planar.is_some() {
            // The packing has no extent in y: its cell grid is one layer.
            "neighbours(cell list, one layer of cells: 2D, skin rebuild)".to_string()
        } else {
            "neighbours(cell list, skin rebuild)".to_string()
        });
        let (normal, tangential) = (self.normal.name(), self.tangential.description());
        // With no material below e = 1 the tangential dashpot's coefficient is zero: the plan
        // says so.
        let idle = if self.tangential.damped() && !self.dashpot { " (0: every e = 1)" } else { "" };
        let mut c = format!("contacts({normal} + {tangential}{idle} + coulomb");
        if self.bonds {
            c.push_str(", bonds");
        }
        if self.dashpot {
            c.push_str(", normal dashpot");
        }
        if self.rotation {
            c.push_str(", torques");
        }
        if self.planar.is_some() {
            // The pair arithmetic in the x–z plane: two components (CPU lanes, GPU constants).
            c.push_str("; 2D: in the x–z plane");
        }
        c.push(')');
        stages.push(c);
        // The force stages, in step order, before the body forces and the move.
        stages.extend(self.words_of(Role::Force));
        let mut body = Vec::new();
        if self.gravity {
            body.push("gravity".to_string());
        }
        if self.damping > 0.0 {
            body.push(format!("viscous damping {:.3} of critical", self.damping));
        }
        if self.local_damping > 0.0 {
            body.push(format!("local damping α = {:.2}", self.local_damping));
        }
        if !body.is_empty() {
            stages.push(body.join(" + "));
        }
        let integrate = match (self.rotation, self.planar) {
            (true, Some(_)) => "integrate(leapfrog, rotation about y; 2D: y and spin about x, z held)",
            (false, Some(_)) => "integrate(leapfrog; 2D: y held)",
            (true, None) => "integrate(leapfrog, rotation)",
            (false, None) => "integrate(leapfrog)",
        };
        stages.push(integrate.to_string());
        stages.extend(self.words_of(Role::Body));
        stages.extend(self.words_of(Role::Field));
        writeln!(f, "step plan: {}", stages.join(" → "))?;
        let names: Vec<&str> = self.stages().iter().map(|s| s.name()).collect();
        writeln!(f, "stages: {}", names.join(" → "))?;
        let sets: Vec<String> = self
            .lane_sets()
            .iter()
            .map(|s| match (s.bytes_per_entry, s.bytes_per_row_entry) {
                (0, 0) => format!("{} {} B ({})", s.stage, s.bytes_per_particle, s.lanes.join(", ")),
                (0, r) => {
                    format!("{} {} B + {r} B per row entry ({})", s.stage, s.bytes_per_particle, s.lanes.join(", "))
                }
                (e, _) => {
                    format!("{} {} B + {e} B per bond end ({})", s.stage, s.bytes_per_particle, s.lanes.join(", "))
                }
            })
            .collect();
        writeln!(f, "lanes per particle (cpu, f64): {} = {} B", sets.join(" + "), self.bytes_per_particle())?;
        if let Some(p) = &self.pore_flow {
            if gpu {
                writeln!(f, "pore network (gpu, f32): about {} B ({})", p.device_bytes(), p.device_lanes().join("; "))?;
            } else {
                writeln!(f, "pore network (cpu, f64): about {} B ({})", p.bytes(), p.lanes().join("; "))?;
            }
        }
        let mut off = Vec::new();
        if !self.rotation {
            off.push("rotation");
        }
        if !self.bonds {
            off.push("bonds");
        }
        if !self.dashpot {
            off.push("contact dashpot");
        }
        if !self.gravity {
            off.push("gravity");
        }
        if self.damping == 0.0 {
            off.push("viscous damping");
        }
        if self.local_damping == 0.0 {
            off.push("local damping");
        }
        if self.walls == 0 {
            off.push("walls");
        }
        // Then the effects the plan does not run, in step order.
        off.extend(REGISTRY.iter().filter(|e| e.effect && !(e.runs)(self)).map(|e| e.off));
        write!(f, "not simulated: {}", off.join(", "))
    }
}
