//! Atomic output writes: every file a run writes (CSV, charts, pictures, checkpoints,
//! snapshots, the run record) goes through [`write`], so an interrupted or crashed run leaves
//! each file either whole or as it was before, never half written.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `bytes` to `path`: the data goes to a hidden temporary file in the same folder
/// (same file system, so the rename is atomic), is flushed to disk, then renamed over
/// `path`. Missing parent folders are created. On error the temporary file is removed and
/// the target is left as it was.
pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_with(path, |file| file.write_all(bytes))
}

/// [`write`] for data made piece by piece (a movie's frames): `fill` writes the temporary
/// file, which is then flushed to disk and renamed over `path`, or removed if anything fails.
pub fn write_with(path: &Path, fill: impl FnOnce(&mut fs::File) -> std::io::Result<()>) -> std::io::Result<()> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{} does not name a file", path.display()))
    })?;
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    fs::create_dir_all(&dir)?;
    // The rename would replace whatever `path` is: only a plain file (or nothing) may be
    // replaced, never a device, a pipe, a folder or a link.
    match fs::symlink_metadata(path) {
        Ok(meta) if !meta.file_type().is_file() => {
            return Err(std::io::Error::new(
                std::io::ErrorKind::AlreadyExists,
                format!("{} exists and is not a regular file; refusing to replace it", path.display()),
            ))
        }
        _ => {}
    }
    // Unique per process and per call, so two writers of one file never share a temporary.
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".{}-{}.tmp", std::process::id(), COUNTER.fetch_add(1, Ordering::Relaxed)));
    let tmp = dir.join(tmp_name);
    let result = (|| {
        let mut file = fs::File::create(&tmp)?;
        fill(&mut file)?;
        file.sync_all()?;
        drop(file);
        fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::FileTypeExt;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("matdem-atomic-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn write_creates_folders_replaces_the_file_and_leaves_no_temporary() {
        let dir = scratch("replace");
        let path = dir.join("a/b/status.csv");
        write(&path, b"first").unwrap();
        write(&path, b"second, longer").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second, longer");
        assert_eq!(entries(&dir.join("a/b")), ["status.csv"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_removes_its_temporary() {
        let dir = scratch("fail");
        let path = dir.join("model.mdem");
        write(&path, b"old").unwrap();
        // A folder where the rename wants to put the file: the rename fails after the data
        // was written to the temporary.
        let blocked = dir.join("blocked");
        fs::create_dir_all(blocked.join("inner")).unwrap();
        assert!(write(&blocked, b"new").is_err());
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert_eq!(entries(&dir), ["blocked", "model.mdem"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_device_a_pipe_a_folder_or_a_link_is_never_replaced() {
        let dir = scratch("special");
        fs::create_dir_all(dir.join("folder")).unwrap();
        std::os::unix::fs::symlink("/dev/null", dir.join("link")).unwrap();
        assert!(std::process::Command::new("mkfifo").arg(dir.join("fifo")).status().unwrap().success());
        for target in [dir.join("folder"), dir.join("link"), dir.join("fifo"), PathBuf::from("/dev/full")] {
            let e = write(&target, b"x").unwrap_err();
            assert!(e.to_string().contains("is not a regular file"), "{}: {e}", target.display());
        }
        assert!(fs::symlink_metadata(dir.join("fifo")).unwrap().file_type().is_fifo());
        assert!(fs::symlink_metadata("/dev/full").unwrap().file_type().is_char_device());
        assert_eq!(entries(&dir), ["fifo", "folder", "link"]);
        fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_path_without_a_file_name_is_refused() {
        let e = write(Path::new("/"), b"x").unwrap_err();
        assert!(e.to_string().contains("does not name a file"), "{e}");
    }
}
