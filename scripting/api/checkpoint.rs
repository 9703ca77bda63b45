//! Saving and loading models (MatDEM: `save` of the model's .mat file, then `load` in the next
//! script): `d.save("name")` writes `name.mdem` into the run's output folder; `load_model("name")`
//! reads it back — from the output folder, or from the script's own folder — so the build →
//! cut/assign → test steps can be separate scripts.

use super::model::{ModelData, ModelHandle};
use super::snapshots::SnapshotLog;
use super::table::TableData;
use super::{err, Host, RhaiResult};
use matdem_engine::checkpoint::{decode, encode, Checkpoint};
use rhai::{Dynamic, Engine};
use serde::{Deserialize, Serialize};
use std::rc::Rc;

/// The extension of checkpoint files, added when a name has none.
pub const EXTENSION: &str = "mdem";

/// What the host keeps with a model in its checkpoint: the name, the record table and the
/// snapshot series.
#[derive(Serialize, Deserialize)]
struct ModelAnnex {
    name: String,
    /// `d.status` columns; values as bits so NaN back-fills survive exactly.
    status: Vec<(String, Vec<u64>)>,
    rows: usize,
    /// The snapshot series, so a resumed run keeps writing it (`load_model` starts none).
    #[serde(default)]
    snapshots: SnapshotLog,
    /// The movie being taken, so a resumed run continues it (`load_model` starts none).
    #[serde(default)]
    movie: crate::movie::MovieState,
}

/// `name` with `.mdem` added when it has no extension.
fn with_extension(name: &str) -> String {
    if std::path::Path::new(name).extension().is_some() {
        name.to_string()
    } else {
        format!("{name}.{EXTENSION}")
    }
}

/// Checkpoint bytes of a model and its host data.
pub fn checkpoint_bytes(data: &ModelData) -> Vec<u8> {
    let t = data.status.0.borrow();
    let annex = ModelAnnex {
        name: data.name.clone(),
        status: t.columns.iter().map(|(c, v)| (c.clone(), v.iter().map(|x| x.to_bits()).collect())).collect(),
        rows: t.rows,
        snapshots: data.snapshots.borrow().clone(),
        movie: data.movie.borrow().state.clone(),
    };
    let annex = ron::to_string(&annex).expect("strings and integers always serialise");
    encode(&data.sim.model, annex.as_bytes())
}

/// Puts a loaded checkpoint into `data`: the model, and the record table in place (script
/// variables holding `d.status` keep seeing it).
pub fn restore(data: &mut ModelData, ck: Checkpoint) -> Result<(), String> {
    let annex = host_annex(&ck.annex)?;
    data.sim.replace_model(ck.model);
    data.name = annex.name;
    *data.status.0.borrow_mut() = table_of(annex.status, annex.rows);
    *data.snapshots.borrow_mut() = annex.snapshots;
    {
        // The movie the replayed script started took no frame: the restored one replaces it.
        let mut movie = data.movie.borrow_mut();
        movie.state = annex.movie;
        movie.state.reopen();
    }
    super::model::install_observers(data);
    Ok(())
}

fn host_annex(bytes: &[u8]) -> Result<ModelAnnex, String> {
    std::str::from_utf8(bytes)
        .map_err(|e| e.to_string())
        .and_then(|s| ron::from_str::<ModelAnnex>(s).map_err(|e| e.to_string()))
        .map_err(|e| format!("its host data (name, records) is unreadable ({e}); save the model again"))
}

fn table_of(columns: Vec<(String, Vec<u64>)>, rows: usize) -> TableData {
    TableData::from_columns(
        columns.into_iter().map(|(c, v)| (c, v.into_iter().map(f64::from_bits).collect())).collect(),
        rows,
    )
}

/// Reads and decodes checkpoint `name` (see [`Host::read_input`]) into a new model.
fn load(host: &Host, name: &str) -> RhaiResult<ModelHandle> {
    let (path, bytes) = host.read_input(
        &with_extension(name),
        &format!(
            "no saved model `{name}`; save it first with d.save(\"{name}\") or put its .mdem file beside the script"
        ),
    )?;
    let ck = decode(&bytes).map_err(|e| err(format!("cannot load {path}: {e}")))?;
    let annex = host_annex(&ck.annex).map_err(|e| err(format!("cannot load {path}: {e}")))?;
    let handle = host.adopt(&annex.name, ck.model);
    *handle.data().status.0.borrow_mut() = table_of(annex.status, annex.rows);
    Ok(handle)
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    let h = host.clone();
    engine.register_fn("save", move |d: &mut ModelHandle, name: &str| -> RhaiResult<Dynamic> {
        h.observe("save", || {
            let path = h.out_path(&with_extension(name))?;
            let bytes = checkpoint_bytes(&d.data());
            crate::atomic_write::write(&path, &bytes)
                .map_err(|e| err(format!("cannot write {}: {e}", path.display())))?;
            h.note_written([path.clone()]);
            Ok(Dynamic::from(path.display().to_string()))
        })
    });
    engine.register_fn("load_model", move |name: &str| load(&host, name));
}
