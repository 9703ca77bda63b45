//! The periodic cell's state in the model (`effects::EffectStates::periodic`): its setting
//! alone (the cell moves the core's lanes and keeps none), which a checkpoint carries as its
//! `periodic` section.

use crate::effects::periodic::setting::Periodic;
use crate::effects::{EffectState, Fit, NewElement};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PeriodicState {
    /// The cell (`None`: no axis repeats).
    pub cell: Option<Periodic>,
}

impl EffectState for PeriodicState {
    const NAME: &'static str = "periodic";
    type Settings = Option<Periodic>;

    fn settings(&self) -> &Option<Periodic> {
        &self.cell
    }

    fn push(&mut self, _: &NewElement) {}

    fn retain(&mut self, _: &[bool]) {}

    fn bytes(&self) -> usize {
        0
    }

    fn check(&self, _: &Fit) -> Result<(), String> {
        let Some(cell) = &self.cell else { return Ok(()) };
        let sound = cell.axes.iter().flatten().all(|[lo, hi]| lo.is_finite() && hi.is_finite() && hi > lo)
            && cell.shear.is_none_or(|s| {
                [s.rate, s.offset, s.offset_at_build].iter().all(|v| v.is_finite())
                    && cell.axes[0].is_some()
                    && cell.axes[2].is_some()
            });
        if !sound || cell.axes.iter().all(Option::is_none) {
            return Err("the periodic cell's spans are not finite [lo, hi) with lo < hi".into());
        }
        Ok(())
    }
}
