//! The guard's setting, held by the model's [`Settings`](crate::model::Settings); the guard
//! itself is `guard.rs`.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::str::FromStr;

/// What the guard does when a contact is too stiff for the time step: stop the run (the
/// default) or warn once on stderr and go on (`d.guard = "warn"`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum GuardMode {
    #[default]
    Stop,
    Warn,
}

impl FromStr for GuardMode {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "stop" => Ok(GuardMode::Stop),
            "warn" => Ok(GuardMode::Warn),
            _ => Err(Error::unknown("guard mode", s, &["stop", "warn"])),
        }
    }
}
