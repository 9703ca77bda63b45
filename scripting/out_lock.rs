//! One run per output folder. A run (or a REPL session, or a study) holds an advisory lock
//! on `OUT/.matdem-rs.lock` while it writes there; a second one into the same folder is
//! refused with the holder named, instead of the two overwriting each other's files. The
//! lock is the operating system's (`flock`), so a run that dies releases it.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// The lock's file name at the top of the output folder.
pub const LOCK_FILE: &str = ".matdem-rs.lock";

/// The held lock; dropping it removes the file and releases the folder.
#[derive(Debug)]
pub struct OutLock {
    file: File,
    path: PathBuf,
}

impl OutLock {
    /// Locks `out_dir` (created if missing) for `what` (e.g. "run examples/oedometer"), or
    /// says who holds it.
    pub fn acquire(out_dir: &Path, what: &str) -> Result<OutLock, String> {
        std::fs::create_dir_all(out_dir)
            .map_err(|e| format!("cannot create output folder {}: {e}", out_dir.display()))?;
        let path = out_dir.join(LOCK_FILE);
        // A holder that is releasing removes the file after we opened it: lock the file the
        // path names now, and try again when it was replaced under us.
        for _ in 0..8 {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&path)
                .map_err(|e| format!("cannot create the lock {}: {e}", path.display()))?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    let holder = holder.trim();
                    let holder = if holder.is_empty() { "another matdem-rs process" } else { holder };
                    return Err(format!(
                        "output folder {} is in use by {holder}; wait for it to finish, or give this run another \
                         --out",
                        out_dir.display()
                    ));
                }
                Err(TryLockError::Error(e)) => return Err(format!("cannot lock {}: {e}", path.display())),
            }
            if !same_file(&file, &path) {
                continue;
            }
            let note = format!("matdem-rs pid {} ({what})\n", std::process::id());
            let written = file.set_len(0).and_then(|()| file.rewind()).and_then(|()| file.write_all(note.as_bytes()));
            written.map_err(|e| format!("cannot write the lock {}: {e}", path.display()))?;
            return Ok(OutLock { file, path });
        }
        Err(format!("cannot lock {}: it keeps being replaced by another process", path.display()))
    }
}

fn same_file(file: &File, path: &Path) -> bool {
    match (file.metadata(), std::fs::metadata(path)) {
        (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
        _ => false,
    }
}

impl Drop for OutLock {
    fn drop(&mut self) {
        // Removed while still locked, so no one can lock the old file after us (see acquire).
        let _ = std::fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_on_a_folder_is_refused_naming_the_holder_and_released_on_drop() {
        let dir = std::env::temp_dir().join(format!("matdem-lock-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let first = OutLock::acquire(&dir, "run first.rhai").unwrap();
        let e = OutLock::acquire(&dir, "run second.rhai").unwrap_err();
        assert!(e.contains("in use by matdem-rs pid") && e.contains("run first.rhai") && e.contains("--out"), "{e}");
        drop(first);
        assert!(!dir.join(LOCK_FILE).exists());
        let again = OutLock::acquire(&dir, "run third.rhai").unwrap();
        drop(again);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
