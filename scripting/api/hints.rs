//! What to write instead, when a script calls a function, uses a property or names a variable
//! that the API or the script does not have. Users come from MatDEM and write its names
//! (`b.buildInitialModel()`, `b.sampleW`, `d.setGroupMat`): Rhai only says "Function not
//! found". A hint names, in this order, how a known name is called (it was called with other
//! arguments), the name MatDEM's call has here (from the "(MatDEM …)" notes of the
//! reference), the snake_case spelling of a camelCase name, or the nearest known name; else
//! where every name is listed. A variable the script never made gets the nearest of its own,
//! and MATLAB's habits (`%` comments, 'single-quoted' strings, `x(1)`, `1e5` steps) what Rhai
//! writes instead.

use super::docs::{functions, properties};
use matdem_engine::error::edit_distance;
use rhai::EvalAltResult;

/// A hint for an error of a call, a property or a variable the script or the API does not
/// have (`source`: the text of the script the error is in, for its own variables' names);
/// `None` for any other error.
pub fn for_error(e: &EvalAltResult, source: &str) -> Option<String> {
    match e {
        EvalAltResult::ErrorVariableNotFound(name, _) => variable_hint(name, source),
        EvalAltResult::ErrorFunctionNotFound(signature, _) => {
            // "name (Type, Type)", or for a property reached as a call "get$name (Type)".
            let name = signature.split(" (").next().unwrap_or(signature).trim();
            let args = signature.get(name.len()..).unwrap_or("").trim();
            match name.strip_prefix("get$").or_else(|| name.strip_prefix("set$")) {
                Some(property) => Some(property_hint(property, None)),
                // MATLAB indexes with parentheses: `x(1)` of an array the script made.
                None if usages_of(name).is_empty() && declared_names(source).iter().any(|n| n == name) => {
                    Some(format!("`{name}` is a variable, not a function: index an array with {name}[0] (from 0)"))
                }
                None => Some(function_hint(name, args)),
            }
        }
        EvalAltResult::ErrorParsing(..) => matlab_habit(&e.to_string()),
        // "Unknown property 'x' - a getter is not registered for type 'Box'", "No writable
        // property 'x' - a setter is not registered for type 'Box' to handle 'string'".
        EvalAltResult::ErrorDotExpr(message, _) if message.contains("property '") => {
            let quoted: Vec<&str> = message.split('\'').skip(1).step_by(2).collect();
            let name = quoted.first()?;
            let setting = match quoted.as_slice() {
                [_, whose, given] if message.contains("to handle") => Some((*whose, *given)),
                _ => None,
            };
            Some(property_hint(name, setting))
        }
        _ => None,
    }
}

/// A syntax error that MATLAB's habits make (MatDEM's scripts are MATLAB): `%` comments and
/// strings in single quotes.
fn matlab_habit(message: &str) -> Option<String> {
    if message.contains("Unexpected '%'") {
        return Some("comments start with // here (MATLAB's % is the remainder operator)".to_string());
    }
    // "Invalid character: 'Standard'": Rhai's single quotes hold one character.
    let rest = message.split("Invalid character: '").nth(1)?;
    // Rhai's message may end with its position: "… 'Standard' (line 2, position 11)".
    let quoted = rest.split(" (line ").next()?.strip_suffix('\'')?;
    (quoted.chars().count() > 1)
        .then(|| format!("strings take double quotes here: \"{quoted}\" (single quotes hold one character)"))
}

/// What to look up instead of `name`, a function or property the reference has no entry
/// for (the REPL's `:help name`), if anything near it is known.
pub fn for_name(name: &str) -> Option<String> {
    [function_hint(name, ""), property_hint(name, None)].into_iter().find(|h| h != NO_HINT)
}

/// The hint when nothing near was found.
const NO_HINT: &str = "`matdem-rs doc` lists every function and property a script can use";

/// The hint for a function `name` called with `args` (Rhai's "(Type, …)").
fn function_hint(name: &str, args: &str) -> String {
    // `d.len()`, `d.count()`: an array's or a mask's habit; the model's count is a property.
    if matches!(name, "len" | "length" | "size" | "count" | "numel") && args.starts_with("(Model") {
        return "the model's number of elements is the property `d.n` (MatDEM d.aNum)".to_string();
    }
    let usages = usages_of(name);
    if !usages.is_empty() {
        let given = if args.is_empty() { String::new() } else { format!(" (it was given {args})") };
        // `d.run(1e5)`: Rhai reads 1e5 as a float, and counts are integers.
        let count = if args.contains("f64") && usages.iter().any(|u| u.contains("steps") || u.contains("n)")) {
            "; a count of steps is an integer: 100000, not 1e5 or 100000.0"
        } else {
            ""
        };
        return format!("`{name}` is called as {}{given}{count}", usages.join(", or "));
    }
    if let Some(ours) = matdem_name(name, Kind::Function) {
        return format!("MatDEM's `{name}` is `{ours}` here: {}", usages_of(&ours).join(", or "));
    }
    let snake = snake_case(name);
    if snake != name && !usages_of(&snake).is_empty() {
        return format!("did you mean `{snake}`? {}", usages_of(&snake).join(", or "));
    }
    match nearest(name, &function_names()) {
        Some(near) => format!("did you mean `{near}`? {}", usages_of(&near).join(", or ")),
        None => NO_HINT.to_string(),
    }
}

/// The hint for a property `name`; `setting` is (the type, the type of the value) when a
/// value was set that the property does not take.
fn property_hint(name: &str, setting: Option<(&str, &str)>) -> String {
    let whose = owners_of(name);
    if let Some((owner, given)) = setting {
        let row = properties().find(|(n, w, _)| *n == name && w.split(' ').next() == Some(owner));
        if let Some((_, _, doc)) = row {
            return format!("`{name}` of {owner} is {doc}: it cannot be set to a {given}");
        }
    }
    if !whose.is_empty() {
        return format!("`{name}` is a property of {}", whose.join(", of "));
    }
    if name == "mo" {
        return "MatDEM's `d.mo` arrays are the model's own properties here: d.x, d.y, d.z, d.r, d.vx, … (d.mo.aZ \
                is d.z; `matdem-rs doc` lists them)"
            .to_string();
    }
    if let Some(ours) = matdem_name(name, Kind::Property) {
        return format!("MatDEM's `{name}` is `{ours}` here (a property of {})", owners_of(&ours).join(", of "));
    }
    let snake = snake_case(name);
    if snake != name && !owners_of(&snake).is_empty() {
        return format!("did you mean `{snake}`? (a property of {})", owners_of(&snake).join(", of "));
    }
    let names: Vec<&str> = properties().map(|(n, _, _)| *n).collect();
    match nearest(name, &names) {
        Some(near) => format!("did you mean `{near}`? (a property of {})", owners_of(&near).join(", of ")),
        None => NO_HINT.to_string(),
    }
}

/// The hint for a variable `name` the script has not made, if there is one to give.
fn variable_hint(name: &str, source: &str) -> Option<String> {
    let usages = usages_of(name);
    if !usages.is_empty() {
        return Some(format!("`{name}` is a function: call it as {}", usages.join(", or ")));
    }
    match name {
        "mfs" => {
            return Some(
                "MatDEM's mfs.makeBox, mfs.makeColumn, mfs.makeRing, … are plain functions here: make_box(…), \
                 make_column(…), make_ring(…) (`matdem-rs doc`)"
                    .to_string(),
            )
        }
        "B" | "b" | "d" => {
            return Some(format!(
                "a script makes its own objects with let, as MatDEM's scripts do with =: `let b = new_box(\"name\")`, \
                 `let d = b.build_initial_model()`{}",
                nearest(name, &declared_names(source))
                    .map(|n| format!(" (or did you mean `{n}`?)"))
                    .unwrap_or_default()
            ))
        }
        _ => {}
    }
    nearest(name, &declared_names(source)).map(|n| format!("did you mean `{n}`?"))
}

/// The names a script declares: after `let`, `const` and `for`, and each `fn`'s name and
/// parameters.
fn declared_names(source: &str) -> Vec<String> {
    let ident = |c: char| c.is_ascii_alphanumeric() || c == '_';
    let words: Vec<&str> = source.split(|c: char| !ident(c)).filter(|w| !w.is_empty()).collect();
    let mut out: Vec<String> = words
        .windows(2)
        .filter(|pair| matches!(pair[0], "let" | "const" | "for"))
        .map(|pair| pair[1].to_string())
        .collect();
    // `fn name(a, b)`: every word up to the closing parenthesis.
    for (k, _) in source.match_indices("fn ") {
        if source[..k].chars().next_back().is_none_or(|c| !ident(c)) {
            let head = &source[k + 3..];
            let head = &head[..head.find(')').unwrap_or(head.len())];
            out.extend(head.split(|c: char| !ident(c)).filter(|w| !w.is_empty()).map(str::to_string));
        }
    }
    out.sort();
    out.dedup();
    out
}

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Function,
    Property,
}

/// Our name for MatDEM's `name` (`setGroupMat` of `d.setGroupMat`, `aZ` of `d.mo.aZ`), read
/// from the "(MatDEM …)" notes of the reference's entries of that kind.
fn matdem_name(name: &str, kind: Kind) -> Option<String> {
    let rows: Vec<(&str, &str)> = match kind {
        Kind::Function => functions().map(|(n, _, doc)| (*n, *doc)).collect(),
        Kind::Property => properties().map(|(n, _, doc)| (*n, *doc)).collect(),
    };
    rows.into_iter()
        .find(|(_, doc)| matdem_names_in(doc).iter().any(|m| m.eq_ignore_ascii_case(name)))
        .map(|(ours, _)| ours.to_string())
}

/// The MatDEM names a reference entry notes, after "MatDEM ": the parts of each dotted name
/// longer than two letters and its last (`d.mo.aX(ids) = v, d.mo.aKN(ids) = v` gives aX
/// and aKN, `Tool_Cut.addSurf` both).
fn matdem_names_in(doc: &str) -> Vec<&str> {
    let mut out = Vec::new();
    for note in doc.split("MatDEM ").skip(1) {
        // The note runs to the parenthesis that closes "(MatDEM …)".
        let mut depth = 0usize;
        let end = note
            .char_indices()
            .find(|&(_, c)| match c {
                '(' => {
                    depth += 1;
                    false
                }
                ')' if depth == 0 => true,
                ')' => {
                    depth -= 1;
                    false
                }
                _ => false,
            })
            .map_or(note.len(), |(k, _)| k);
        for part in note[..end].split(", ") {
            let dotted: &str =
                part.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == '.')).next().unwrap_or("");
            // Each part but the object names (`d`, `B`, `mo`): `Tool_Cut.addSurf` is a call
            // of MatDEM's Tool_Cut, which cut_surface stands for too.
            let parts: Vec<&str> = dotted.split('.').filter(|p| !p.is_empty()).collect();
            for (k, part) in parts.iter().enumerate() {
                if part.len() > 2 || k + 1 == parts.len() {
                    out.push(*part);
                }
            }
        }
    }
    out
}

/// How the reference says `name` is called: its native entries' usages, or a stdlib
/// procedure's `name(params)`.
fn usages_of(name: &str) -> Vec<String> {
    let native: Vec<String> = functions().filter(|(n, _, _)| *n == name).map(|(_, u, _)| format!("`{u}`")).collect();
    if !native.is_empty() {
        return native;
    }
    stdlib_procedures().into_iter().filter(|(n, _)| n == name).map(|(_, u)| format!("`{u}` (stdlib)")).collect()
}

/// The types a property belongs to, as the reference says ("Model (read, set)").
fn owners_of(name: &str) -> Vec<String> {
    properties().filter(|(n, _, _)| *n == name).map(|(_, whose, _)| whose.to_string()).collect()
}

/// Every function name a script can call: the native ones and the stdlib procedures.
fn function_names() -> Vec<String> {
    let mut names: Vec<String> = functions().map(|(n, _, _)| n.to_string()).collect();
    names.extend(stdlib_procedures().into_iter().map(|(n, _)| n));
    names
}

/// The stdlib's public procedures as (name, `name(params)`), read from their sources
/// (`fn name(…) {` at the start of a line; `private fn` is left out).
fn stdlib_procedures() -> Vec<(String, String)> {
    crate::stdlib::SCRIPTS
        .iter()
        .flat_map(|(_, source)| source.lines())
        .filter_map(|line| {
            let rest = line.strip_prefix("fn ")?;
            let usage = &rest[..rest.find(')')? + 1];
            Some((usage.split('(').next()?.trim().to_string(), usage.to_string()))
        })
        .collect()
}

/// `setGroupMat` → `set_group_mat`, `sampleW` → `sample_w`, `ballR` → `ball_r`.
fn snake_case(name: &str) -> String {
    let mut out = String::new();
    for (k, c) in name.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if k > 0 && !out.ends_with('_') {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// The known name closest to `name`, if it is within a third of `name`'s length in edits
/// (at least 1, at most 3): a typo, not a different word.
fn nearest<S: AsRef<str>>(name: &str, known: &[S]) -> Option<String> {
    let limit = (name.chars().count() / 3).clamp(1, 3);
    known
        .iter()
        .map(|k| (edit_distance(&name.to_lowercase(), k.as_ref()), k.as_ref()))
        .filter(|(d, _)| *d <= limit)
        .min()
        .map(|(_, k)| k.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn not_found(signature: &str) -> String {
        let e = EvalAltResult::ErrorFunctionNotFound(signature.into(), rhai::Position::NONE);
        for_error(&e, "").unwrap()
    }

    fn no_property(message: &str) -> String {
        for_error(&EvalAltResult::ErrorDotExpr(message.into(), rhai::Position::NONE), "").unwrap()
    }

    fn no_variable(name: &str, source: &str) -> Option<String> {
        for_error(&EvalAltResult::ErrorVariableNotFound(name.into(), rhai::Position::NONE), source)
    }

    #[test]
    fn an_unknown_variable_gets_the_scripts_nearest_name() {
        let script = "let sample = 3;\nconst limit = 2;\nfor step in 0..3 {}\nfn load(stress, opts) {}\nprint(sampel);";
        assert_eq!(declared_names(script), ["limit", "load", "opts", "sample", "step", "stress"]);
        assert_eq!(no_variable("sampel", script).unwrap(), "did you mean `sample`?");
        assert_eq!(no_variable("stres", script).unwrap(), "did you mean `stress`?");
        assert_eq!(no_variable("unrelated", script), None);
        // MatDEM's objects: made with let here.
        assert!(no_variable("B", "").unwrap().starts_with("a script makes its own objects with let"));
        assert!(no_variable("mfs", "").unwrap().contains("make_box(…)"));
        // A function named without its call.
        assert!(no_variable("linspace", "").unwrap().starts_with("`linspace` is a function: call it as"));
    }

    #[test]
    fn a_property_set_to_a_value_it_does_not_take_says_what_it_is() {
        let h =
            no_property("No writable property 'ball_r' - a setter is not registered for type 'Box' to handle 'string'");
        assert!(h.starts_with("`ball_r` of Box is "), "{h}");
        assert!(h.ends_with(": it cannot be set to a string"), "{h}");
    }

    #[test]
    fn a_known_function_with_other_arguments_is_shown_with_its_usage() {
        let h = not_found("set_type (Box, i64)");
        assert!(h.starts_with("`set_type` is called as `b.set_type(\"top_platen\")`"), "{h}");
        assert!(h.ends_with("(it was given (Box, i64))"), "{h}");
        let h = not_found("sediment (Model)");
        assert!(h.contains("`sediment(d, opts)` (stdlib)"), "{h}");
    }

    #[test]
    fn matdem_names_lead_to_ours() {
        // From a "(MatDEM d.setGroupMat)" note, whatever the case of the script's spelling.
        assert!(not_found("setGroupMat (Model, string, Material)")
            .starts_with("MatDEM's `setGroupMat` is `set_group_mat` here: `d.set_group_mat(group, material)`"));
        assert!(not_found("delElement (Model, i64)").starts_with("MatDEM's `delElement` is `delete` here"));
        assert!(not_found("addFixId (Model, string)").starts_with("MatDEM's `addFixId` is `fix` here"));
        assert!(not_found("addSurf (array)").starts_with("MatDEM's `addSurf` is `cut_surface` here"));
        assert!(not_found("Tool_Cut (Model)").starts_with("MatDEM's `Tool_Cut` is `cut_surface` here"));
        // A MatDEM name the notes leave out, by its snake_case spelling.
        let h = not_found("buildInitialModel (Box)");
        assert!(h.starts_with("did you mean `build_initial_model`? `b.build_initial_model() -> Model`"), "{h}");
        assert!(no_property(
            "No writable property 'sampleW' - a setter is not registered for type 'Box' to handle 'f64'"
        )
        .starts_with("MatDEM's `sampleW` is `sample_w` here (a property of Box"));
        assert!(no_property("Unknown property 'aZ' - a getter is not registered for type 'Model'")
            .starts_with("MatDEM's `aZ` is `z` here"));
        assert!(no_property("Unknown property 'aNum' - a getter is not registered for type 'Model'")
            .starts_with("MatDEM's `aNum` is `n` here (a property of Model"));
        // How many elements: a property, not an array's len() or a mask's count().
        for call in ["len (Model)", "count (Model)", "size (Model)"] {
            assert_eq!(not_found(call), "the model's number of elements is the property `d.n` (MatDEM d.aNum)");
        }
        assert!(not_found("count (Field)").starts_with("`count` is called as `mask.count() -> int`"));
        assert!(no_property("Unknown property 'mo' - a getter is not registered for type 'Model'")
            .contains("d.mo.aZ is d.z"));
    }

    #[test]
    fn a_typo_gets_the_nearest_name_and_a_stranger_the_reference() {
        assert!(not_found("sedimen (i64)").starts_with("did you mean `sediment`? `sediment(d, opts)` (stdlib)"));
        assert!(not_found("balanse (Model)").starts_with("did you mean `balance`?"));
        assert!(no_property("Unknown property 'smaple_w' - a getter is not registered for type 'Box'")
            .starts_with("did you mean `sample_w`?"));
        assert_eq!(
            not_found("frobnicate (Model)"),
            "`matdem-rs doc` lists every function and property a script can use"
        );
        // A two-letter name is not a typo of every other two-letter name.
        assert!(!not_found("qq (i64)").starts_with("did you mean"));
        assert!(for_error(&EvalAltResult::ErrorRuntime("x".into(), rhai::Position::NONE), "").is_none());
    }

    #[test]
    fn a_property_of_another_type_names_its_owner() {
        let h = no_property("Unknown property 'ball_r' - a getter is not registered for type 'Model'");
        assert!(h.starts_with("`ball_r` is a property of Box"), "{h}");
    }

    #[test]
    fn every_alias_of_a_note_is_read() {
        assert_eq!(matdem_names_in("writes a lane (MatDEM d.mo.aX(ids) = v, d.mo.aKN(ids) = v); more"), ["aX", "aKN"]);
        assert_eq!(matdem_names_in("a surface (MatDEM Tool_Cut.addSurf)"), ["Tool_Cut", "addSurf"]);
        assert!(matdem_names_in("no note here").is_empty());
    }

    #[test]
    fn matlab_habits_are_named() {
        let parse = |text: &str| {
            let e: EvalAltResult = rhai::Engine::new().compile(text).unwrap_err().into();
            for_error(&e, text)
        };
        assert_eq!(
            parse("% a comment\nlet x = 1;").unwrap(),
            "comments start with // here (MATLAB's % is the remainder operator)"
        );
        assert_eq!(
            parse("d.balance('Standard');").unwrap(),
            "strings take double quotes here: \"Standard\" (single quotes hold one character)"
        );
        assert_eq!(parse("let x = (1 + ;"), None);
        // `x(1)` of an array the script made, and a float for a step count.
        let e = EvalAltResult::ErrorFunctionNotFound("x (i64)".into(), rhai::Position::NONE);
        assert!(for_error(&e, "let x = [1, 2];\nx(1)").unwrap().starts_with("`x` is a variable, not a function"));
        assert!(not_found("run (Model, f64)").ends_with("a count of steps is an integer: 100000, not 1e5 or 100000.0"));
        assert!(!not_found("run (Model, string)").contains("a count of steps"));
    }

    #[test]
    fn camel_case_becomes_snake_case() {
        assert_eq!(snake_case("setGroupMat"), "set_group_mat");
        assert_eq!(snake_case("sampleW"), "sample_w");
        assert_eq!(snake_case("already_snake"), "already_snake");
    }
}
