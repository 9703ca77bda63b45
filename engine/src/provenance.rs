//! Where each of a material's values came from: given, derived by a formula, left at a
//! default, trained or rescaled. A material prints it, so a value nobody chose (ν = 0,
//! E = Kn/(πR)) is never silent.

use serde::{Deserialize, Serialize};

/// How one value came to be.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Source {
    /// Given by the user (a definition or a later assignment).
    Given,
    /// Left at a default nobody gave; says what the default means.
    Default(String),
    /// Computed from other values; the formula, written out.
    Derived(String),
    /// Found by MatDEM's training; what it was trained for.
    Trained(String),
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Source::Given => f.write_str("given"),
            Source::Default(why) => write!(f, "default: {why}"),
            Source::Derived(how) => write!(f, "derived: {how}"),
            Source::Trained(what) => write!(f, "trained: {what}"),
        }
    }
}

/// The source of each value that has one, by the value's script name (`kn`, `young`, …), in
/// the order they were first recorded.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    entries: Vec<(String, Source)>,
}

impl Provenance {
    /// Records (or replaces) where `key` came from.
    pub fn set(&mut self, key: &str, source: Source) {
        match self.entries.iter_mut().find(|(k, _)| k == key) {
            Some(e) => e.1 = source,
            None => self.entries.push((key.to_string(), source)),
        }
    }

    /// Records the same source for several values.
    pub fn set_all(&mut self, keys: &[&str], source: Source) {
        for k in keys {
            self.set(k, source.clone());
        }
    }

    pub fn of(&self, key: &str) -> Option<&Source> {
        self.entries.iter().find(|(k, _)| k == key).map(|(_, s)| s)
    }

    pub fn iter(&self) -> impl Iterator<Item = (&str, &Source)> {
        self.entries.iter().map(|(k, s)| (k.as_str(), s))
    }
}
