//! Moisture's state in the model (`effects::EffectStates::moisture`): the scene's settings and
//! the water lanes, one object that grows with the elements and that a checkpoint carries as
//! its `moisture` section.

use crate::effects::moisture::lanes::MoistureLanes;
use crate::effects::moisture::physics::Table;
use crate::effects::moisture::settings::MoistureSettings;
use crate::effects::{EffectState, Fit, NewElement};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MoistureState {
    pub settings: MoistureSettings,
    pub lanes: MoistureLanes,
}

impl EffectState for MoistureState {
    const NAME: &'static str = "moisture";
    type Settings = MoistureSettings;

    fn settings(&self) -> &MoistureSettings {
        &self.settings
    }

    /// A new element starts at the initial water content with its material's diffusivity.
    fn push(&mut self, e: &NewElement) {
        self.lanes.push(e.id, self.settings.initial, e.radius);
        if let Some(d) = self.lanes.diffusivity.get_mut(e.id) {
            *d = self.settings.diffusivity(e.material, e.base_material);
        }
    }

    fn retain(&mut self, keep: &[bool]) {
        self.lanes.retain(keep);
    }

    /// A radius set by hand is the radius at which the shrinkage table's factor is 1.
    fn radius_set(&mut self, i: usize, r: f64) {
        if let Some(r0) = self.lanes.radius0.get_mut(i) {
            *r0 = r;
        }
    }

    fn bytes(&self) -> usize {
        self.lanes.bytes()
    }

    fn check(&self, fit: &Fit) -> Result<(), String> {
        if !self.lanes.consistent(fit.elements) {
            return Err("water lanes do not match the particles".into());
        }
        if let Some((i, r)) = self.lanes.radius0.iter().enumerate().find(|(_, r)| !(r.is_finite() && **r > 0.0)) {
            return Err(format!(
                "particle {i} has radius at which the shrinkage table is 1 {r} m: a radius is a finite number > 0"
            ));
        }
        // The tables are read at their first point and searched in order: as the setters make
        // them (Table::new), or refused.
        let s = &self.settings;
        for (table, what, hi) in [(&s.radius_table, "radius", f64::MAX), (&s.strength_table, "strength", 1.0)] {
            if let Some(t) = table {
                Table::new(t.points.clone(), &format!("the moisture {what} table"), 0.0, hi)?;
            }
        }
        Ok(())
    }
}
