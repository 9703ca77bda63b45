//! The script reference cannot go stale: every registered function and property has an
//! entry in scripting/api/docs.rs, and docs/script-reference.md is what `matdem-rs doc`
//! prints.

use crate::common::*;
use matdem_rs::api::reference::{markdown, undocumented};

fn engine() -> rhai::Engine {
    matdem_rs::new_engine(std::rc::Rc::new(matdem_rs::api::Host::new(temp_dir("reference"))))
}

#[test]
fn every_registered_function_and_property_is_documented() {
    let missing = undocumented(&engine());
    assert!(missing.is_empty(), "registered but not in scripting/api/docs.rs: {missing:?}");
}

#[test]
fn every_documented_property_is_registered() {
    let registered = matdem_rs::api::reference::registered(&engine());
    for (name, _, _) in matdem_rs::api::docs::PROPERTIES {
        let p = matdem_rs::api::reference::Registered::Property(name.to_string());
        assert!(registered.contains(&p), "docs property `{name}` is not a registered property");
    }
}

#[test]
fn the_generated_reference_file_is_up_to_date() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/script-reference.md");
    let on_disk = std::fs::read_to_string(&path).unwrap_or_default();
    let o = bin().arg("doc").output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o), markdown(&engine()));
    assert!(
        on_disk == stdout(&o),
        "docs/script-reference.md is out of date: run `cargo run --release -- doc > docs/script-reference.md`"
    );
}
