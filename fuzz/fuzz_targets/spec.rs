//! Fuzz target: the spec loader (`lincal_core::spec::from_yaml_str`) on any text.
//!
//! Whatever the bytes (taken as UTF-8, invalid sequences replaced), loading must return a
//! spec or a located error: no panic, no hang, no unbounded allocation (the loader's bounds:
//! 1 MiB, 64 levels, 100 000 nodes, expression depth and length).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    match lincal_core::spec::from_yaml_str(&text, Some("fuzz.yaml")) {
        Ok(spec) => {
            // A loaded spec is consistent: its data layout can be formed.
            let layout = lincal_core::data::DataLayout::of_spec(&spec);
            assert_eq!(layout.joints, spec.joints.len());
            assert!(spec.dim == 2 || spec.dim == 3, "dim {}", spec.dim);
        }
        Err(e) => {
            // Every error says something, and its message can be written.
            assert!(!e.diagnostics().is_empty());
            let _ = e.to_string();
        }
    }
});
