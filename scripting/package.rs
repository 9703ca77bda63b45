//! Packaged simulators: a folder (or one tar archive of it) holding `simulator.ron` — name,
//! version, description, entry script, typed and documented parameters, outputs — with its
//! scripts and data. `matdem-rs info` prints the parameters, `run --set` checks values
//! against them before anything runs, `pack` writes the archive. An archive is read into
//! memory and never extracted.

pub mod fixes;

use crate::sandbox::ReadRoot;
use rhai::Dynamic;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Read;
use std::path::{Component, Path, PathBuf};
use std::rc::Rc;

/// The manifest's file name, at the package's root.
pub const MANIFEST: &str = "simulator.ron";

/// The largest archive `run` and `info` read into memory.
const MAX_ARCHIVE_BYTES: u64 = 512 << 20;

/// `simulator.ron`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub name: String,
    pub version: String,
    pub description: String,
    /// The script `run` starts, relative to the package root.
    pub entry: String,
    #[serde(default)]
    pub parameters: Vec<Parameter>,
    /// What a run writes into its output folder, for people (not checked).
    #[serde(default)]
    pub outputs: Vec<String>,
}

/// One parameter the script reads as `params.NAME`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Parameter {
    pub name: String,
    #[serde(rename = "type")]
    pub kind: ParamType,
    /// Absent: the script decides when the parameter is not given (`params.NAME` is `()`).
    #[serde(default)]
    pub default: Option<ParamValue>,
    #[serde(default)]
    pub unit: Option<String>,
    /// Inclusive bounds, for `int` and `float`.
    #[serde(default)]
    pub range: Option<(f64, f64)>,
    /// The values a `string` may take (empty: any string).
    #[serde(default)]
    pub choices: Vec<String>,
    #[serde(default)]
    pub help: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ParamType {
    Bool,
    Int,
    Float,
    String,
}

/// A value as written in the manifest.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum ParamValue {
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
}

impl std::fmt::Display for ParamType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ParamType::Bool => "bool",
            ParamType::Int => "int",
            ParamType::Float => "float",
            ParamType::String => "string",
        })
    }
}

impl std::fmt::Display for ParamValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamValue::Bool(b) => write!(f, "{b}"),
            ParamValue::Int(i) => write!(f, "{i}"),
            ParamValue::Float(x) => write!(f, "{x:?}"),
            ParamValue::Str(s) => write!(f, "\"{s}\""),
        }
    }
}

impl Parameter {
    /// The value for the script, or why `text` is not one this parameter takes.
    pub fn parse(&self, text: &str) -> Result<Dynamic, String> {
        let bad = |what: String| {
            format!(
                "--set {}={text}: {what}; `{}`{} is {}{}",
                self.name,
                self.name,
                self.unit.as_ref().map(|u| format!(" [{u}]")).unwrap_or_default(),
                self.allowed(),
                if self.help.is_empty() { String::new() } else { format!(" ({})", self.help) },
            )
        };
        let number = match self.kind {
            ParamType::Bool => {
                return match text {
                    "true" => Ok(Dynamic::TRUE),
                    "false" => Ok(Dynamic::FALSE),
                    _ => Err(bad(format!("`{text}` is not a bool"))),
                }
            }
            ParamType::String => {
                if !self.choices.is_empty() && !self.choices.iter().any(|c| c == text) {
                    let known: Vec<&str> = self.choices.iter().map(String::as_str).collect();
                    let hint = matdem_engine::error::did_you_mean(text, &known);
                    return Err(bad(format!("`{text}` is not one of the choices{hint}")));
                }
                return Ok(Dynamic::from(text.to_string()));
            }
            ParamType::Int => {
                text.parse::<i64>().map(|i| i as f64).map_err(|_| bad(format!("`{text}` is not an integer")))?
            }
            ParamType::Float => match text.parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => return Err(bad(format!("`{text}` is not a finite number"))),
            },
        };
        if let Some((lo, hi)) = self.range {
            if !(lo..=hi).contains(&number) {
                return Err(bad("out of range".to_string()));
            }
        }
        Ok(match self.kind {
            ParamType::Int => Dynamic::from_int(number as i64),
            _ => Dynamic::from_float(number),
        })
    }

    /// "a float within 0.05 … 10", for messages.
    fn allowed(&self) -> String {
        let article = if self.kind == ParamType::Int { "an" } else { "a" };
        match (self.kind, self.range) {
            (ParamType::Bool, _) => "a bool: true or false".to_string(),
            (ParamType::String, _) if !self.choices.is_empty() => format!("one of {}", self.choice_list()),
            (k, Some((lo, hi))) => format!("{article} {k} within {lo} … {hi}"),
            (k, None) => format!("{article} {k}"),
        }
    }

    /// "`fast`, `exact`", for messages and `info`.
    fn choice_list(&self) -> String {
        self.choices.iter().map(|c| format!("`{c}`")).collect::<Vec<_>>().join(", ")
    }

    /// The default as the script sees it; `None` when the manifest gives none.
    fn default_value(&self) -> Option<Dynamic> {
        self.default.as_ref().map(|v| match (v, self.kind) {
            (ParamValue::Bool(b), _) => Dynamic::from_bool(*b),
            (ParamValue::Int(i), ParamType::Float) => Dynamic::from_float(*i as f64),
            (ParamValue::Int(i), _) => Dynamic::from_int(*i),
            (ParamValue::Float(x), _) => Dynamic::from_float(*x),
            (ParamValue::Str(s), _) => Dynamic::from(s.clone()),
        })
    }

    /// Checks the manifest's own entry: a known type, a default of that type inside the range.
    fn validate(&self) -> Result<(), String> {
        let ok_name = !self.name.is_empty()
            && self.name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && !self.name.starts_with(|c: char| c.is_ascii_digit());
        if !ok_name {
            return Err(format!("parameter name `{}` must be letters, digits and `_`", self.name));
        }
        check_param_name(&self.name)?;
        if let Some((lo, hi)) = self.range {
            if !matches!(self.kind, ParamType::Int | ParamType::Float)
                || lo.partial_cmp(&hi) == Some(std::cmp::Ordering::Greater)
                || lo.is_nan()
                || hi.is_nan()
            {
                return Err(format!("parameter `{}`: a range needs an int or float type and low <= high", self.name));
            }
        }
        if !self.choices.is_empty() {
            let mut seen = std::collections::BTreeSet::new();
            if self.kind != ParamType::String || self.choices.iter().any(|c| c.is_empty() || !seen.insert(c)) {
                return Err(format!(
                    "parameter `{}`: choices need a string type and distinct, non-empty values",
                    self.name
                ));
            }
        }
        let Some(d) = &self.default else { return Ok(()) };
        let text = match d {
            ParamValue::Str(s) => s.clone(),
            other => other.to_string(),
        };
        let type_ok = matches!(
            (d, self.kind),
            (ParamValue::Bool(_), ParamType::Bool)
                | (ParamValue::Int(_), ParamType::Int | ParamType::Float)
                | (ParamValue::Float(_), ParamType::Float)
                | (ParamValue::Str(_), ParamType::String)
        );
        if !type_ok {
            return Err(format!("parameter `{}`: default {d} is not {}", self.name, self.allowed()));
        }
        self.parse(&text).map(|_| ()).map_err(|e| format!("parameter `{}`: the default is refused: {e}", self.name))
    }
}

/// RON as manifests are written: optional fields take a bare value (`unit: "mm"`, not `Some("mm")`).
fn ron_options() -> ron::Options {
    ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
}

/// A package opened from a folder or an archive.
#[derive(Debug, Clone)]
pub struct Package {
    pub manifest: Manifest,
    /// What the script may read: the folder, or the archive's files in memory.
    pub root: ReadRoot,
    /// The folder or archive as given, for messages.
    pub location: PathBuf,
}

impl Package {
    /// A package when `path` is a folder or an archive, `None` when it is a plain script.
    pub fn detect(path: &Path) -> Result<Option<Package>, String> {
        if path.is_dir() {
            return Package::open(path).map(Some);
        }
        if path.extension().is_some_and(|e| e == "tar") {
            return Package::open(path).map(Some);
        }
        Ok(None)
    }

    /// Opens a package folder or `.tar` archive and checks its manifest.
    pub fn open(path: &Path) -> Result<Package, String> {
        let root = if path.is_dir() {
            if !path.join(MANIFEST).is_file() {
                return Err(format!(
                    "{} is a folder without {MANIFEST}: a packaged simulator needs one (see examples/oedometer/)",
                    path.display()
                ));
            }
            ReadRoot::folder(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?
        } else {
            let files = read_archive(path)?;
            ReadRoot::Archive { label: format!("archive {}", path.display()), files: Rc::new(files) }
        };
        let text = root.read(MANIFEST).map_err(|e| format!("{}: {e}", path.display()))?;
        let text = String::from_utf8(text).map_err(|_| format!("{}: {MANIFEST} is not UTF-8", path.display()))?;
        let manifest: Manifest =
            ron_options().from_str(&text).map_err(|e| format!("{}/{MANIFEST}: {e}", path.display()))?;
        let package = Package { manifest, root, location: path.to_path_buf() };
        package.validate()?;
        Ok(package)
    }

    fn validate(&self) -> Result<(), String> {
        let m = &self.manifest;
        let at = format!("{}/{MANIFEST}", self.location.display());
        // The name and version become paths (`out/NAME`, `NAME-VERSION.tar`): a received
        // package must not be able to point them anywhere else.
        check_path_word("name", &m.name, 64).map_err(|e| format!("{at}: {e}"))?;
        check_path_word("version", &m.version, 32).map_err(|e| format!("{at}: {e}"))?;
        for (k, p) in m.parameters.iter().enumerate() {
            p.validate().map_err(|e| format!("{at}: {e}"))?;
            if m.parameters[..k].iter().any(|q| q.name == p.name) {
                return Err(format!("{at}: parameter `{}` is declared twice", p.name));
            }
        }
        self.root.read(&m.entry).map_err(|e| format!("{at}: the entry script: {e}"))?;
        Ok(())
    }

    /// The entry script's text.
    pub fn entry_text(&self) -> Result<String, String> {
        let bytes = self.root.read(&self.manifest.entry)?;
        String::from_utf8(bytes).map_err(|_| format!("{} is not UTF-8 text", self.manifest.entry))
    }

    /// Where the entry script is, for error reports.
    pub fn entry_label(&self) -> String {
        match &self.root {
            ReadRoot::Archive { .. } => format!("{}:{}", self.location.display(), self.manifest.entry),
            _ => self.location.join(&self.manifest.entry).display().to_string(),
        }
    }

    /// The parameters for the script: every default, then each `--set NAME=VALUE` checked
    /// against its declaration. Nothing runs when one is refused.
    pub fn params(&self, set: &[String]) -> Result<Vec<(String, Dynamic)>, String> {
        let m = &self.manifest;
        let mut values: Vec<(String, Dynamic)> =
            m.parameters.iter().filter_map(|p| p.default_value().map(|v| (p.name.clone(), v))).collect();
        for s in set {
            let (name, text) = s
                .split_once('=')
                .map(|(k, v)| (k.trim(), v.trim()))
                .filter(|(k, _)| !k.is_empty())
                .ok_or_else(|| format!("--set expects NAME=VALUE, got `{s}`"))?;
            let p = m.parameters.iter().find(|p| p.name == name).ok_or_else(|| self.unknown(name, text))?;
            let v = p.parse(text)?;
            match values.iter_mut().find(|(n, _)| n == name) {
                Some(slot) => slot.1 = v,
                None => values.push((name.to_string(), v)),
            }
        }
        Ok(values)
    }

    fn unknown(&self, name: &str, text: &str) -> String {
        let names: Vec<&str> = self.manifest.parameters.iter().map(|p| p.name.as_str()).collect();
        let hint = matdem_engine::error::did_you_mean(name, &names);
        format!(
            "--set {name}={text}: simulator `{}` has no parameter `{name}`{hint}; its parameters: {} \
             (`matdem-rs info {}` describes them)",
            self.manifest.name,
            names.join(", "),
            self.location.display()
        )
    }

    /// The manifest for people: description, a table of parameters, outputs. Text for a
    /// terminal: every field a manifest brings is shown with its control characters escaped.
    pub fn describe(&self) -> String {
        let m = &self.manifest;
        let shown = |t: &str| crate::terminal_text::one_line(t).into_owned();
        let mut s = format!(
            "{} {} — {}\nentry: {}\n\n",
            shown(&m.name),
            shown(&m.version),
            shown(&m.description),
            shown(&m.entry)
        );
        let rows: Vec<[String; 6]> = m
            .parameters
            .iter()
            .map(|p| {
                [
                    p.name.clone(),
                    p.kind.to_string(),
                    p.default.as_ref().map_or("(unset)".to_string(), |d| d.to_string()),
                    p.unit.clone().unwrap_or_else(|| "-".to_string()),
                    match p.range {
                        Some((lo, hi)) => format!("{lo} … {hi}"),
                        None if !p.choices.is_empty() => p.choices.join(" | "),
                        None => "-".to_string(),
                    },
                    p.help.clone(),
                ]
                .map(|cell| shown(&cell))
            })
            .collect();
        let header = ["parameter", "type", "default", "unit", "range", "help"].map(String::from);
        let widths: Vec<usize> =
            (0..6).map(|k| rows.iter().chain([&header]).map(|r| r[k].chars().count()).max().unwrap_or(0)).collect();
        for row in [&header].into_iter().chain(rows.iter()) {
            let cells: Vec<String> = row.iter().zip(&widths).map(|(c, w)| format!("{c:<w$}")).collect();
            let _ = writeln!(s, "{}", cells.join("  ").trim_end());
        }
        if !m.outputs.is_empty() {
            let _ = writeln!(s, "\noutputs:");
            for o in &m.outputs {
                let _ = writeln!(s, "  {}", shown(o));
            }
        }
        let _ = writeln!(s, "\nrun: matdem-rs run {} --set NAME=VALUE", self.location.display());
        s
    }
}

/// Refuses a parameter name the script could not write as `params.NAME` (a Rhai keyword
/// or reserved word such as `case`, `fn` or `match`).
pub fn check_param_name(name: &str) -> Result<(), String> {
    let identifier = name.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_')
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    if !identifier {
        return Err(format!(
            "parameter name `{}` is not a name a script can write as `params.NAME`: use letters, digits and `_`, \
             starting with a letter (e.g. `load_mpa`)",
            name.escape_debug()
        ));
    }
    if rhai::Engine::new_raw().compile_expression(format!("params.{name}")).is_ok() {
        return Ok(());
    }
    Err(format!(
        "parameter name `{name}` is a word Rhai reserves, so a script cannot read it as `params.{name}`; choose \
         another name (e.g. `{name}_name`)"
    ))
}

/// Refuses a manifest `name` or `version` that is not a plain file name: 1 to `max`
/// letters, digits, `.`, `_` or `-`, starting with a letter or digit (so never `..`, `/`,
/// an absolute path or a hidden name).
fn check_path_word(field: &str, value: &str, max: usize) -> Result<(), String> {
    let ok = !value.is_empty()
        && value.len() <= max
        && value.starts_with(|c: char| c.is_ascii_alphanumeric())
        && value.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-'));
    if ok {
        return Ok(());
    }
    Err(format!(
        "{field} `{}` is refused: it names the default output folder and archive, so it must be 1 to {max} \
         letters, digits, `.`, `_` or `-`, starting with a letter or digit (e.g. `oedometer`, `1.2.0`)",
        value.escape_debug()
    ))
}

/// The regular files of a tar archive, by relative path. Links, devices, absolute paths and
/// `..` are refused; an archive whose files sit in one top folder is read from inside it.
fn read_archive(path: &Path) -> Result<BTreeMap<String, Vec<u8>>, String> {
    let at = |e: String| format!("archive {}: {e}", path.display());
    let file = std::fs::File::open(path).map_err(|e| at(format!("cannot open it: {e}")))?;
    let mut archive = tar::Archive::new(file);
    let mut files = BTreeMap::new();
    let mut total = 0u64;
    for entry in archive.entries().map_err(|e| at(format!("not a tar archive: {e}")))? {
        let mut entry = entry.map_err(|e| at(format!("not a readable tar archive: {e}")))?;
        let raw = entry.path().map_err(|e| at(e.to_string()))?.into_owned();
        let kind = entry.header().entry_type();
        if kind.is_dir() {
            continue;
        }
        if !kind.is_file() {
            return Err(at(format!(
                "{} is not a plain file (a link or device); a package holds plain files only",
                raw.display()
            )));
        }
        let mut parts = Vec::new();
        for c in raw.components() {
            match c {
                Component::Normal(s) => parts.push(s.to_string_lossy().into_owned()),
                Component::CurDir => {}
                _ => return Err(at(format!("entry {} leaves the archive (absolute or `..`); refused", raw.display()))),
            }
        }
        total += entry.size();
        if total > MAX_ARCHIVE_BYTES {
            return Err(at(format!(
                "holds more than {MAX_ARCHIVE_BYTES} bytes; a package is scripts and data, not a model dump"
            )));
        }
        let mut bytes = Vec::with_capacity(entry.size() as usize);
        entry.read_to_end(&mut bytes).map_err(|e| at(format!("cannot read {}: {e}", raw.display())))?;
        let name = parts.join("/");
        // tar lets a later entry shadow an earlier one; which copy runs must not be a guess.
        if files.insert(name.clone(), bytes).is_some() {
            return Err(at(format!(
                "holds `{name}` twice (a later entry would silently replace the first); repack it with \
                 `matdem-rs pack FOLDER`"
            )));
        }
    }
    let manifests: Vec<&str> =
        files.keys().map(String::as_str).filter(|k| *k == MANIFEST || k.ends_with(&format!("/{MANIFEST}"))).collect();
    if manifests.len() > 1 {
        return Err(at(format!(
            "holds {} manifests ({}); a package has one {MANIFEST}, so which one runs would be a guess",
            manifests.len(),
            manifests.join(", ")
        )));
    }
    if !files.contains_key(MANIFEST) {
        // `tar cf pkg.tar oedometer/` puts everything under one folder: read from inside it.
        let tops: std::collections::BTreeSet<&str> =
            files.keys().map(|k| k.split_once('/').map_or(k.as_str(), |(t, _)| t)).collect();
        let top = match tops.iter().next() {
            Some(t) if tops.len() == 1 && files.contains_key(&format!("{t}/{MANIFEST}")) => t.to_string(),
            _ => {
                return Err(at(format!(
                    "has no {MANIFEST} at its root (nor one top folder holding it and everything else); make \
                     one with `matdem-rs pack FOLDER`"
                )))
            }
        };
        let prefix = format!("{top}/");
        files = files.into_iter().filter_map(|(k, v)| k.strip_prefix(&prefix).map(|k| (k.to_string(), v))).collect();
    }
    Ok(files)
}

/// Writes the package folder `dir` as one tar archive at `out`: every plain file (hidden
/// files skipped), sorted, with fixed times and modes, so the same folder packs to the same
/// bytes. Returns the number of files packed.
pub fn pack(dir: &Path, out: &Path) -> Result<usize, String> {
    if !dir.is_dir() {
        return Err(format!("{} is not a folder; pack takes a package folder", dir.display()));
    }
    // Only a package that would open is packed.
    Package::open(dir)?;
    let mut names = Vec::new();
    collect_files(dir, Path::new(""), &mut names)?;
    let out_abs = std::path::absolute(out).ok();
    // The limits `run` and `info` apply to an archive, applied before anything is read: an
    // archive they would refuse is never written.
    let mut total = 0u64;
    for rel in &names {
        let full = dir.join(rel);
        total += std::fs::metadata(&full).map_err(|e| format!("cannot read {}: {e}", full.display()))?.len();
        if total > MAX_ARCHIVE_BYTES {
            return Err(format!(
                "{} holds more than {MAX_ARCHIVE_BYTES} bytes of files (first past it: {}), more than `run` and \
                 `info` take from an archive; a package is scripts and data, not a model dump: leave large files \
                 out (build the model in the script) or share them apart",
                dir.display(),
                rel.display()
            ));
        }
    }
    let mut builder = tar::Builder::new(Vec::new());
    let mut count = 0;
    for rel in &names {
        let full = dir.join(rel);
        if out_abs.is_some() && std::path::absolute(&full).ok() == out_abs {
            continue;
        }
        let bytes = std::fs::read(&full).map_err(|e| format!("cannot read {}: {e}", full.display()))?;
        let mut header = tar::Header::new_ustar();
        header.set_size(bytes.len() as u64);
        header.set_mode(0o644);
        header.set_mtime(0);
        header.set_entry_type(tar::EntryType::Regular);
        let name = rel.to_string_lossy().replace('\\', "/");
        builder.append_data(&mut header, &name, bytes.as_slice()).map_err(|e| format!("cannot pack {name}: {e}"))?;
        count += 1;
    }
    let bytes = builder.into_inner().map_err(|e| format!("cannot finish the archive: {e}"))?;
    crate::atomic_write::write(out, &bytes).map_err(|e| format!("cannot write {}: {e}", out.display()))?;
    Ok(count)
}

pub(crate) fn collect_files(root: &Path, rel: &Path, out: &mut Vec<PathBuf>) -> Result<(), String> {
    let dir = root.join(rel);
    let mut entries: Vec<_> = std::fs::read_dir(&dir)
        .map_err(|e| format!("cannot list {}: {e}", dir.display()))?
        .collect::<Result<_, _>>()
        .map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let name = e.file_name();
        if name.to_string_lossy().starts_with('.') {
            continue;
        }
        let path = rel.join(&name);
        let kind = e.file_type().map_err(|err| format!("cannot read {}: {err}", e.path().display()))?;
        if kind.is_symlink() {
            return Err(format!(
                "{} is a symbolic link; a package holds plain files only (copy the file in instead)",
                e.path().display()
            ));
        } else if kind.is_dir() {
            collect_files(root, &path, out)?;
        } else if kind.is_file() {
            out.push(path);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn param(ron_text: &str) -> Parameter {
        ron_options().from_str(ron_text).unwrap()
    }

    #[test]
    fn values_are_typed_and_range_checked_with_the_reason() {
        let p = param(r#"(name: "dt_rate", type: float, default: 1.0, unit: "×", range: (0.05, 10.0), help: "step")"#);
        assert_eq!(p.parse("2").unwrap().as_float().unwrap(), 2.0);
        let e = p.parse("50").unwrap_err();
        assert!(e.contains("dt_rate=50") && e.contains("out of range") && e.contains("0.05 … 10"), "{e}");
        assert!(p.parse("NaN").unwrap_err().contains("not a finite number"));
        let b = param(r#"(name: "quick", type: bool, default: false)"#);
        assert!(b.parse("yes").unwrap_err().contains("true or false"));
        let i = param(r#"(name: "seed", type: int, default: 3, range: (0, 10))"#);
        assert_eq!(i.parse("7").unwrap().as_int().unwrap(), 7);
        assert!(i.parse("7.5").unwrap_err().contains("not an integer"));
    }

    #[test]
    fn a_parameter_name_that_is_no_identifier_is_called_so_and_a_keyword_reserved() {
        for bad in ["a b", "../x", "a,b", "", "1a", "a.b", "a-b"] {
            let e = check_param_name(bad).unwrap_err();
            assert!(e.contains("is not a name a script can write"), "{bad:?}: {e}");
        }
        assert!(check_param_name("match").unwrap_err().contains("a word Rhai reserves"));
        assert!(check_param_name("_load2").is_ok());
    }

    #[test]
    fn a_default_outside_its_range_is_refused() {
        let p = param(r#"(name: "n", type: int, default: 30, range: (0, 10))"#);
        assert!(p.validate().unwrap_err().contains("out of range"));
        let q = param(r#"(name: "n", type: bool, default: 3)"#);
        assert!(q.validate().unwrap_err().contains("not a bool"));
    }
}
