//! How the host ends a script early. The reason travels as a [`Stop`] inside Rhai's
//! termination error: a script can neither catch a termination nor make a `Stop` (the type
//! has no constructor in the script API), so no script can forge or swallow one — unlike a
//! marker string, which `throw` could imitate and `try`/`catch` could hide.

use rhai::{Dynamic, EvalAltResult, Position};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stop {
    /// `matdem-rs plan`: the plan of the first run or balance is printed; nothing runs.
    PlanDone,
    /// Ctrl-C or SIGTERM during a run or balance: the resume folder is written.
    Interrupted,
    /// Ctrl-C or SIGTERM where there is no resume point (a script loop, a box build).
    Stopped,
}

impl Stop {
    /// The error that unwinds the script with this reason.
    pub fn unwind(self) -> Box<EvalAltResult> {
        Box::new(EvalAltResult::ErrorTerminated(self.token(), Position::NONE))
    }

    /// The value Rhai's progress callback returns to terminate a script with this reason.
    pub fn token(self) -> Dynamic {
        Dynamic::from(self)
    }

    /// The reason an error ended the script, if the host ended it (looking through the
    /// function calls and modules the termination passed).
    pub fn of(e: &EvalAltResult) -> Option<Stop> {
        match e {
            EvalAltResult::ErrorTerminated(v, _) => v.clone().try_cast::<Stop>(),
            EvalAltResult::ErrorInFunctionCall(_, _, inner, _) | EvalAltResult::ErrorInModule(_, inner, _) => {
                Stop::of(inner)
            }
            _ => None,
        }
    }
}
