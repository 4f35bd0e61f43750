//! Fuzz target: URDF import (`lincal_core::urdf::import`) and the URDF reader on any text.
//!
//! The first byte chooses the chain's ends among the links the text names (so a mutated
//! robot still imports through a real chain) and the convention; the rest is the URDF.
//! Import must return a spec or a located error: no panic, no stack overflow on any
//! nesting, no unbounded allocation (the reader keeps at most a few times the input). An
//! imported spec must load, and every error carries a diagnostic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lincal_core::urdf::{import, read, ConstraintChoice, ImportOptions};

fuzz_target!(|data: &[u8]| {
    let Some((&choice, rest)) = data.split_first() else {
        return;
    };
    let text = String::from_utf8_lossy(rest);
    let robot = match read::read(&text, "fuzz.urdf") {
        Ok(r) => r,
        Err(e) => {
            assert!(!e.diagnostics().is_empty());
            let _ = e.to_string();
            return;
        }
    };
    let links: Vec<&str> = robot.links.iter().map(|(n, _)| n.as_str()).collect();
    if links.is_empty() {
        return;
    }
    let base = links[usize::from(choice & 0x07) % links.len()];
    let tip = links[usize::from(choice >> 3 & 0x0f) % links.len()];
    let opts = ImportOptions {
        base: base.to_string(),
        tip: tip.to_string(),
        convention: if choice & 0x80 == 0 {
            lincal_core::spec::Convention::Dh
        } else {
            lincal_core::spec::Convention::Mdh
        },
        constraint: ConstraintChoice::Measured,
        path: "fuzz.urdf".to_string(),
        tool: [0.0; 3],
        points: 1,
        distances: Vec::new(),
        command: "lincal import fuzz.urdf".to_string(),
    };
    match import(&text, "fuzz.urdf", &opts) {
        Ok(imported) => {
            lincal_core::spec::from_yaml_str(&imported.yaml, Some("imported.yaml"))
                .expect("an imported spec loads");
        }
        Err(e) => {
            assert!(!e.diagnostics().is_empty());
            let _ = e.to_string();
        }
    }
});
