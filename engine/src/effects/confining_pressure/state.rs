//! The confining pressure's state in the model (`effects::EffectStates::confining_pressure`):
//! its setting alone (it keeps no lanes: the cells are found afresh each step), which a
//! checkpoint carries as its `confining_pressure` section.

use crate::effects::confining_pressure::settings::{Confinement, MAX_CELLS};
use crate::effects::{EffectState, Fit, NewElement};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ConfiningState {
    /// The membrane, while the sample is confined.
    pub confinement: Option<Confinement>,
}

impl EffectState for ConfiningState {
    const NAME: &'static str = "confining_pressure";
    type Settings = Option<Confinement>;

    fn settings(&self) -> &Option<Confinement> {
        &self.confinement
    }

    fn push(&mut self, _: &NewElement) {}

    fn retain(&mut self, _: &[bool]) {}

    fn bytes(&self) -> usize {
        0
    }

    fn check(&self, fit: &Fit) -> Result<(), String> {
        let Some(c) = &self.confinement else { return Ok(()) };
        let cells = c.bands as usize * c.sectors as usize;
        let sound = c.pressure.is_finite() && c.pressure > 0.0 && c.axis.iter().all(|v| v.is_finite());
        if !sound || cells == 0 || cells > MAX_CELLS {
            return Err("the confining pressure is not a finite pressure > 0 on 1 to 2^20 cells".into());
        }
        if !fit.walls.contains(&c.bottom.as_str()) || !fit.walls.contains(&c.top.as_str()) {
            return Err("the confining pressure names a platen the model does not have".into());
        }
        Ok(())
    }
}
