//! ParaView snapshots as scripts see them: `d.snapshot("name")` writes `name.vtp` now;
//! `d.snapshot_every(n)` writes `snapshots/<model>_<step>.vtp` every n steps of every run and
//! balance, listed by time in `<model>.pvd` (see [`crate::snapshot`]); `d.export_elements("name")` writes
//! the elements as a CSV table (or a `.vtp`); `d.export_pores("name")` writes the pore network
//! (pores as points, throats as lines) as `name.vtp`.

use super::model::{ModelData, ModelHandle};
use super::{err, Host, RhaiResult};
use crate::snapshot::{elements_csv, pores_vtp, pvd, vtp};
use matdem_engine::Model;
use rhai::{Dynamic, Engine, INT};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::path::PathBuf;
use std::rc::Rc;

/// A model's snapshot series: its period, where it goes, and what it has written.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct SnapshotLog {
    /// Steps between snapshots; 0 = off.
    pub every: u64,
    /// Series name: files `snapshots/<name>_<step>.vtp` and `<name>.pvd`.
    pub name: String,
    /// Resolved when the series was set up (through the host's output resolver).
    pub folder: PathBuf,
    pub collection: PathBuf,
    /// (time as f64 bits, file relative to the collection), in the order written.
    pub entries: Vec<(u64, String)>,
}

/// Makes the model's simulation write its series (or stop, when `every` is 0).
pub fn install(data: &mut ModelData) {
    super::model::install_observers(data);
}

/// Writes the series' next snapshot of `m` (its observer's call).
pub(super) fn write_next(log: &Rc<RefCell<SnapshotLog>>, m: &Model) -> Result<(), String> {
    let mut log = log.borrow_mut();
    let file = format!("{}_{:09}.vtp", log.name, m.clock.step);
    let path = log.folder.join(&file);
    crate::atomic_write::write(&path, vtp(m).as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    log.entries.push((m.clock.time.to_bits(), format!("snapshots/{file}")));
    let entries: Vec<(f64, String)> = log.entries.iter().map(|(t, f)| (f64::from_bits(*t), f.clone())).collect();
    crate::atomic_write::write(&log.collection, pvd(&entries).as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", log.collection.display()))
}

/// Names become file names: keep them to letters, digits, `_`, `-` and `.`.
fn check_name(name: &str) -> RhaiResult<()> {
    let ok = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || "_-.".contains(c));
    if ok {
        Ok(())
    } else {
        Err(err(format!("snapshot name `{name}` must be letters, digits, `_`, `-` or `.` (e.g. \"sample1\")")))
    }
}

fn snapshot_every(host: &Host, d: &ModelHandle, every: INT, name: Option<&str>) -> RhaiResult<()> {
    if every < 0 {
        return Err(err(format!("snapshot_every: give a number of steps ≥ 1 (0 turns snapshots off), got {every}")));
    }
    let mut data = d.data();
    let name = name.map_or_else(|| data.name.clone(), str::to_string);
    check_name(&name)?;
    let folder = host.out_path("snapshots")?;
    let collection = host.out_path(&format!("{name}.pvd"))?;
    {
        let mut log = data.snapshots.borrow_mut();
        if log.name != name {
            log.entries.clear();
        }
        *log = SnapshotLog { every: every as u64, name, folder, collection, entries: std::mem::take(&mut log.entries) };
    }
    install(&mut data);
    Ok(())
}

pub fn register(engine: &mut Engine, host: Rc<Host>) {
    let h = host.clone();
    engine.register_fn("snapshot", move |d: &mut ModelHandle, name: &str| -> RhaiResult<Dynamic> {
        h.observe("snapshot", || {
            let file =
                if std::path::Path::new(name).extension().is_some() { name.to_string() } else { format!("{name}.vtp") };
            let path = h.out_path(&file)?;
            let text = vtp(&d.data().sim.model);
            crate::atomic_write::write(&path, text.as_bytes())
                .map_err(|e| err(format!("cannot write {}: {e}", path.display())))?;
            h.note_written([path.clone()]);
            Ok(Dynamic::from(path.display().to_string()))
        })
    });
    let h = host.clone();
    engine.register_fn("export_elements", move |d: &mut ModelHandle, name: &str| -> RhaiResult<Dynamic> {
        let ext = std::path::Path::new(name).extension().map(|e| e.to_string_lossy().to_lowercase());
        let file = match ext.as_deref() {
            None => format!("{name}.csv"),
            Some("csv" | "vtp") => name.to_string(),
            Some(other) => {
                return Err(err(format!(
                "export_elements: `{name}`: write a .csv table or a .vtp ParaView file (a name without an extension \
                     gets .csv), not .{other}"
            )))
            }
        };
        h.observe("export_elements", || {
            let path = h.out_path(&file)?;
            let text = {
                let data = d.data();
                if file.to_lowercase().ends_with(".vtp") {
                    vtp(&data.sim.model)
                } else {
                    elements_csv(&data.sim.model)
                }
            };
            crate::atomic_write::write(&path, text.as_bytes())
                .map_err(|e| err(format!("cannot write {}: {e}", path.display())))?;
            h.note_written([path.clone()]);
            Ok(Dynamic::from(path.display().to_string()))
        })
    });
    let h = host.clone();
    engine.register_fn("export_pores", move |d: &mut ModelHandle, name: &str| -> RhaiResult<Dynamic> {
        let ext = std::path::Path::new(name).extension().map(|e| e.to_string_lossy().to_lowercase());
        let file = match ext.as_deref() {
            None => format!("{name}.vtp"),
            Some("vtp") => name.to_string(),
            Some(other) => {
                return Err(err(format!(
                    "export_pores: `{name}`: the pore network is written as a .vtp ParaView file (a name without an \
                     extension gets .vtp), not .{other}"
                )))
            }
        };
        h.observe("export_pores", || {
            let text = pores_vtp(&d.data().sim.model)
                .ok_or_else(|| err("export_pores: pore flow is off; call d.enable(\"pore_flow\") first"))?;
            let path = h.out_path(&file)?;
            crate::atomic_write::write(&path, text.as_bytes())
                .map_err(|e| err(format!("cannot write {}: {e}", path.display())))?;
            h.note_written([path.clone()]);
            Ok(Dynamic::from(path.display().to_string()))
        })
    });
    let h = host.clone();
    engine.register_fn("snapshot_every", move |d: &mut ModelHandle, every: INT| snapshot_every(&h, d, every, None));
    engine.register_fn("snapshot_every", move |d: &mut ModelHandle, every: INT, name: &str| {
        snapshot_every(&host, d, every, Some(name))
    });
}
