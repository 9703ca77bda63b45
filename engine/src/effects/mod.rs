//! The optional effects, one folder each: a stage of the step with its own lanes, allocated
//! only when a scene switches it on. A folder holds everything of its effect — the physics
//! (`physics.rs`), the scene's settings (`settings.rs`), the per-particle lanes (`lanes.rs`),
//! the CPU pass (`cpu.rs`), the GPU kernel (`gpu.rs`, beside `shaders/<name>.wgsl`) and, in
//! `mod.rs`, what a plan takes from the scene and the model-level calls that write its lanes.
//! The core step (walls, neighbour rows, contacts, integration, guard) stays in the backends.
//!
//! This file is the effects' table: a new effect is its folder, its `pub mod` line, its line in
//! `effect_states!` when it keeps state in the model (settings, lanes), and its lines in
//! `with_cpu_passes!` and `with_device_stages!`; its variant, registry row and plan field
//! are in `plan/mod.rs`. The backends, the model and the checkpoint are made from these lists
//! and name no effect (docs/adding-an-effect.md).
pub mod applied_loads;
pub mod buoyancy;
pub mod clumps;
pub mod conduction;
pub mod confining_pressure;
pub mod heat_ledger;
pub mod moisture;
pub mod parallel_bond;
pub mod periodic;
pub mod pore_flow;
pub mod rolling_resistance;

use serde::de::DeserializeOwned;
use serde::Serialize;

/// An element that joined the model, as an effect's state sees it.
pub struct NewElement<'a> {
    pub id: usize,
    pub radius: f64,
    /// Its material's name, and the name a per-element clone (`rock~3`) was cloned from (the
    /// same name for any other material).
    pub material: &'a str,
    pub base_material: &'a str,
}

/// What a state read from a checkpoint must fit: the model's elements and walls.
pub struct Fit<'a> {
    pub elements: usize,
    /// The walls' names, in order.
    pub walls: Vec<&'a str>,
}

/// The state an effect keeps in the model, one object: the scene's settings for it and its
/// per-particle lanes (empty until a plan with its stage allocates them). The model grows and
/// shrinks it with the particles, counts its bytes and compares its settings to decide whether
/// the plan still holds, and a checkpoint carries it as a section of its name.
pub trait EffectState: Default + Clone + PartialEq + Serialize + DeserializeOwned {
    /// The effect's name (its folder's and its stage's), which names its checkpoint section.
    const NAME: &'static str;
    /// What a plan is built from: a change to it rebuilds the plan.
    type Settings: Clone + PartialEq + std::fmt::Debug;
    fn settings(&self) -> &Self::Settings;
    /// A new element joined the model: each allocated lane grows by one.
    fn push(&mut self, e: &NewElement);
    /// Keeps the entries of the elements kept.
    fn retain(&mut self, keep: &[bool]);
    /// Element `i`'s radius was set to `r` by hand.
    fn radius_set(&mut self, _i: usize, _r: f64) {}
    /// Heap bytes of the lanes.
    fn bytes(&self) -> usize;
    /// The checks a state read from a checkpoint passes before the model is stepped: it fits
    /// the model (`fit`) and holds only what the setters allow.
    fn check(&self, fit: &Fit) -> Result<(), String>;
}

/// Declares [`EffectStates`] and [`EffectSettings`], one field per effect that keeps its state
/// in the model (its type in its folder's `state.rs`), and what the model asks of them all.
macro_rules! effect_states {
    ($($(#[$doc:meta])* $name:ident: $state:ty),* $(,)?) => {
        /// The state of each effect that keeps one ([`EffectState`]): a field of the model.
        #[derive(Debug, Clone, Default, PartialEq)]
        pub struct EffectStates {
            $($(#[$doc])* pub $name: $state,)*
        }

        /// Each effect's settings, as a plan was built from them.
        #[derive(Debug, Clone, PartialEq)]
        pub struct EffectSettings {
            $(pub $name: <$state as EffectState>::Settings,)*
        }

        impl EffectStates {
            pub fn push(&mut self, e: &NewElement) {
                $(self.$name.push(e);)*
            }

            pub fn retain(&mut self, keep: &[bool]) {
                $(self.$name.retain(keep);)*
            }

            pub fn radius_set(&mut self, i: usize, r: f64) {
                $(self.$name.radius_set(i, r);)*
            }

            /// Heap bytes of the effects' lanes.
            pub fn bytes(&self) -> usize {
                0 $(+ self.$name.bytes())*
            }

            pub fn settings(&self) -> EffectSettings {
                EffectSettings { $($name: self.$name.settings().clone(),)* }
            }

            /// Whether every effect's settings are `s`'s.
            pub fn settings_are(&self, s: &EffectSettings) -> bool {
                true $(&& *self.$name.settings() == s.$name)*
            }

            /// The states a checkpoint carries (those that differ from a new model's), each as
            /// its name and its postcard bytes.
            pub fn sections(&self) -> Result<Vec<(String, Vec<u8>)>, postcard::Error> {
                let mut out = Vec::new();
                $(if self.$name != <$state>::default() {
                    out.push((<$state as EffectState>::NAME.to_string(), postcard::to_stdvec(&self.$name)?));
                })*
                Ok(out)
            }

            /// Reads the state of the effect `name` from a checkpoint's bytes and checks that it
            /// fits the model.
            pub fn load(&mut self, name: &str, bytes: &[u8], fit: &Fit) -> Result<(), String> {
                $(if name == <$state as EffectState>::NAME {
                    let state: $state = postcard::from_bytes(bytes)
                        .map_err(|e| format!("the {name} section does not read: {e}"))?;
                    state.check(fit)?;
                    self.$name = state;
                    return Ok(());
                })*
                Err(format!("a section of the effect `{name}`, which this build does not know"))
            }
        }
    };
}

effect_states! {
    /// The confining pressure's setting (a triaxial cell's membrane).
    confining_pressure: confining_pressure::state::ConfiningState,
    /// Moisture's settings and water lanes.
    moisture: moisture::state::MoistureState,
    /// The periodic cell's setting.
    periodic: periodic::state::PeriodicState,
}

/// Lists the effects with a CPU pass (`effects::<name>::cpu::stage`), as `Stage` variant and
/// folder, in step order, to the macro `$then` (the CPU backend's stage list is made from it).
/// The heat ledger has none: it is booked inside the passes that dissipate.
#[macro_export]
macro_rules! with_cpu_passes {
    ($then:ident) => {
        $then! {
            ParallelBond parallel_bond,
            RollingResistance rolling_resistance,
            PoreFlow pore_flow,
            AppliedLoads applied_loads,
            ConfiningPressure confining_pressure,
            Buoyancy buoyancy,
            Clumps clumps,
            Periodic periodic,
            Conduction conduction,
            Moisture moisture,
        }
    };
}

/// Lists the effects an upload builds on the GPU through their `gpu.rs`
/// (`effects::<name>::gpu::{SHADER, upload}`), as `Stage` variant and folder, in step order,
/// which is also the order they are built and downloaded in (moisture binds the conduction
/// stage's lanes, so it comes after it), to the macro `$then`. Pore flow and the periodic cell
/// are held by name by the GPU backend, whose batch loop depends on them.
#[macro_export]
macro_rules! with_device_stages {
    ($then:ident) => {
        $then! {
            ParallelBond parallel_bond,
            RollingResistance rolling_resistance,
            AppliedLoads applied_loads,
            ConfiningPressure confining_pressure,
            Buoyancy buoyancy,
            Clumps clumps,
            Conduction conduction,
            Moisture moisture,
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model without elements or walls.
    const NONE: Fit = Fit { elements: 0, walls: Vec::new() };

    #[test]
    fn a_checkpoint_carries_only_the_states_a_new_model_lacks() {
        let mut states = EffectStates::default();
        assert!(states.sections().unwrap().is_empty());
        states.moisture.settings.initial = 0.2;
        let sections = states.sections().unwrap();
        assert_eq!(sections.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), ["moisture"]);
        let mut loaded = EffectStates::default();
        loaded.load(&sections[0].0, &sections[0].1, &NONE).unwrap();
        assert_eq!(loaded, states);
    }

    #[test]
    fn a_section_of_an_unknown_effect_or_bytes_that_do_not_read_are_refused_by_name() {
        let mut states = EffectStates::default();
        let e = states.load("magnetism", &[], &NONE).unwrap_err();
        assert!(e.contains("`magnetism`") && e.contains("does not know"), "{e}");
        let e = states.load("moisture", &[0xff; 3], &NONE).unwrap_err();
        assert!(e.contains("moisture section does not read"), "{e}");
        assert_eq!(states, EffectStates::default());
    }

    #[test]
    fn the_settings_a_plan_was_built_from_tell_a_change() {
        let mut states = EffectStates::default();
        let built = states.settings();
        assert!(states.settings_are(&built));
        states.moisture.lanes.water.push(0.3);
        assert!(states.settings_are(&built), "a lane is not a setting");
        states.moisture.settings.every = 3;
        assert!(!states.settings_are(&built));
    }
}
