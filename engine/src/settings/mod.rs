//! What a scene chooses for the stability guard, as data the model's
//! [`Settings`](crate::model::Settings) holds. No file here names the model, so the model can
//! hold it without the guard, which names the model, becoming its dependency (the engine's
//! modules form no circle: `tests/module_deps.rs`). Each optional effect's settings are in its
//! folder, `effects/<name>/settings.rs`, on the same terms.

pub mod guard;
