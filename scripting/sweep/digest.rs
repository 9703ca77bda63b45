//! The SHA-256 a sweep records for its source, so every point provably runs the same code.
//!
//! A package's digest is of its content — every file's relative path and bytes, sorted by
//! path, hidden files skipped as `pack` skips them — so a folder and the archive `pack` makes
//! of it have the same digest. A plain script's digest is of the script file alone.

use crate::package::Package;
use crate::sandbox::ReadRoot;
use sha2::{Digest, Sha256};
use std::path::Path;

pub fn source_sha256(source: &Path) -> Result<String, String> {
    let Some(package) = Package::detect(source)? else {
        let bytes = std::fs::read(source).map_err(|e| format!("cannot read script {}: {e}", source.display()))?;
        return Ok(crate::run_record::sha256_hex(&bytes));
    };
    let mut files: Vec<(String, Vec<u8>)> = match &package.root {
        ReadRoot::Archive { files, .. } => files.iter().map(|(k, v)| (k.clone(), v.clone())).collect(),
        ReadRoot::Folder(root) => {
            let mut names = Vec::new();
            crate::package::collect_files(root, Path::new(""), &mut names)?;
            names
                .into_iter()
                .map(|rel| {
                    let bytes =
                        std::fs::read(root.join(&rel)).map_err(|e| format!("cannot read {}: {e}", rel.display()))?;
                    Ok((rel.to_string_lossy().replace('\\', "/"), bytes))
                })
                .collect::<Result<_, String>>()?
        }
        ReadRoot::Nothing => Vec::new(),
    };
    files.sort_by(|a, b| a.0.cmp(&b.0));
    let mut h = Sha256::new();
    for (name, bytes) in &files {
        // Lengths first, so no two different file lists hash the same bytes.
        h.update((name.len() as u64).to_le_bytes());
        h.update(name.as_bytes());
        h.update((bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    }
    Ok(h.finalize().iter().map(|b| format!("{b:02x}")).collect())
}
