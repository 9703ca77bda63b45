//! What a scene chooses for the guard and each optional effect, as data: the model's
//! [`Settings`](crate::model::Settings) holds them and the effects read them. No file here
//! names the model, so the model can hold them without its effects' modules, which name the
//! model, becoming its dependencies (the engine's modules form no circle:
//! `tests/module_deps.rs`). Each effect's module re-exports its settings.

pub mod conduction;
pub mod guard;
pub mod moisture;
pub mod water_table;
