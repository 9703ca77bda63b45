//! One run per output folder. A run (or a REPL session, or a study) holds an advisory lock
//! on `OUT/.matdem-rs.lock` while it writes there; a second one into the same folder is
//! refused with the holder named, instead of the two overwriting each other's files. The
//! lock is the operating system's (`flock`), so a run that dies releases it.
//!
//! The folder may have come from elsewhere (a sweep folder copied back from a cluster, a
//! package's output): the lock file is opened without following a link, and only a plain
//! file with no other name is ever written, so a planted `.matdem-rs.lock -> ~/.bashrc` (or a
//! hard link, a FIFO, a device) is refused instead of overwritten.

use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};

/// The lock's file name at the top of the output folder.
pub const LOCK_FILE: &str = ".matdem-rs.lock";

/// What the refusal of a folder in use says, after the folder's name (a sweep recognises a
/// point that another process runs by it).
pub const IN_USE: &str = "is in use by";

/// The held lock; dropping it removes the file and releases the folder.
#[derive(Debug)]
pub struct OutLock {
    file: File,
    path: PathBuf,
    /// Shared holders leave the file (and no note) for the others still holding it.
    shared: bool,
}

impl OutLock {
    /// Locks `out_dir` (created if missing) for `what` (e.g. "run examples/oedometer"), or
    /// says who holds it.
    pub fn acquire(out_dir: &Path, what: &str) -> Result<OutLock, String> {
        Self::lock(out_dir, what, false)
    }

    /// A lock that others of its kind share but no [`OutLock::acquire`] can take while it is
    /// held: the points of a sweep that run at once (Slurm's array tasks) hold it on the sweep
    /// folder, so the plan cannot be replaced under them.
    pub fn acquire_shared(out_dir: &Path, what: &str) -> Result<OutLock, String> {
        Self::lock(out_dir, what, true)
    }

    fn lock(out_dir: &Path, what: &str, shared: bool) -> Result<OutLock, String> {
        // create_dir_all would say only "File exists".
        if let (Ok(link), Err(_)) = (std::fs::read_link(out_dir), std::fs::metadata(out_dir)) {
            return Err(format!(
                "output folder {} is a symbolic link to {}, which does not exist: create that folder, or give \
                 another --out",
                out_dir.display(),
                link.display()
            ));
        }
        std::fs::create_dir_all(out_dir)
            .map_err(|e| format!("cannot create output folder {}: {e}", out_dir.display()))?;
        let path = out_dir.join(LOCK_FILE);
        // A holder that is releasing removes the file after we opened it: lock the file the
        // path names now, and try again when it was replaced under us.
        for _ in 0..8 {
            let mut file = open_plain(&path)?;
            let locked = if shared { file.try_lock_shared() } else { file.try_lock() };
            match locked {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    let holder = holder.trim();
                    let holder = if holder.is_empty() { "other matdem-rs processes" } else { holder };
                    return Err(format!(
                        "output folder {} {IN_USE} {holder}; wait for it to finish, or give this run another \
                         --out",
                        out_dir.display()
                    ));
                }
                Err(TryLockError::Error(e)) => return Err(format!("cannot lock {}: {e}", path.display())),
            }
            if !same_file(&file, &path) {
                continue;
            }
            if shared {
                return Ok(OutLock { file, path, shared });
            }
            let note = format!("matdem-rs pid {} ({what})\n", std::process::id());
            let written = file.set_len(0).and_then(|()| file.rewind()).and_then(|()| file.write_all(note.as_bytes()));
            written.map_err(|e| format!("cannot write the lock {}: {e}", path.display()))?;
            return Ok(OutLock { file, path, shared });
        }
        Err(format!("cannot lock {}: it keeps being replaced by another process", path.display()))
    }

    /// The folder this lock holds.
    pub fn dir(&self) -> &Path {
        self.path.parent().unwrap_or(Path::new("."))
    }
}

/// Opens (or creates) the lock file itself: never through a symbolic link (O_NOFOLLOW), never
/// blocking on a FIFO (O_NONBLOCK), and only a regular file with one name, since the holder
/// writes its note into it.
fn open_plain(path: &Path) -> Result<File, String> {
    let file = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .custom_flags(libc::O_NOFOLLOW | libc::O_NONBLOCK | libc::O_CLOEXEC)
        .open(path)
        .map_err(|e| match e.raw_os_error() {
            Some(libc::ELOOP) => refused(path, "a symbolic link"),
            _ => format!("cannot create the lock {}: {e}", path.display()),
        })?;
    let meta = file.metadata().map_err(|e| format!("cannot read the lock {}: {e}", path.display()))?;
    if !meta.file_type().is_file() {
        return Err(refused(path, "not a plain file"));
    }
    if meta.nlink() != 1 {
        return Err(refused(path, "a hard link to another file"));
    }
    Ok(file)
}

fn refused(path: &Path, what: &str) -> String {
    format!(
        "the lock {} is {what}, which this run would write through: remove it (it is not a lock matdem-rs \
         made), or give this run another --out",
        path.display()
    )
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
        if !self.shared {
            let _ = std::fs::remove_file(&self.path);
        }
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

    #[test]
    fn shared_holders_coexist_and_keep_an_exclusive_one_out() {
        let dir = std::env::temp_dir().join(format!("matdem-lock-shared-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let a = OutLock::acquire_shared(&dir, "sweep point 0").unwrap();
        let b = OutLock::acquire_shared(&dir, "sweep point 1").unwrap();
        let e = OutLock::acquire(&dir, "sweep plan").unwrap_err();
        assert!(e.contains("in use by other matdem-rs processes"), "{e}");
        drop(a);
        assert!(OutLock::acquire(&dir, "sweep plan").is_err());
        drop(b);
        let plan = OutLock::acquire(&dir, "sweep plan").unwrap();
        assert!(OutLock::acquire_shared(&dir, "sweep point 0").unwrap_err().contains("sweep plan"));
        drop(plan);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_planted_link_fifo_or_hard_link_is_refused_and_its_target_left_as_it_was() {
        let dir = std::env::temp_dir().join(format!("matdem-lock-link-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("out")).unwrap();
        let target = dir.join("bashrc");
        std::fs::write(&target, "precious\n").unwrap();
        let lock = dir.join("out").join(LOCK_FILE);
        std::os::unix::fs::symlink(&target, &lock).unwrap();
        let e = OutLock::acquire(&dir.join("out"), "run w.rhai").unwrap_err();
        assert!(e.contains("symbolic link") && e.contains("--out"), "{e}");
        std::fs::remove_file(&lock).unwrap();
        std::fs::hard_link(&target, &lock).unwrap();
        let e = OutLock::acquire(&dir.join("out"), "run w.rhai").unwrap_err();
        assert!(e.contains("hard link"), "{e}");
        std::fs::remove_file(&lock).unwrap();
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "precious\n");
        let status = std::process::Command::new("mkfifo").arg(&lock).status().unwrap();
        assert!(status.success());
        let e = OutLock::acquire(&dir.join("out"), "run w.rhai").unwrap_err();
        assert!(e.contains("not a plain file"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
