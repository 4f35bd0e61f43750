//! trybuild UI tests: each file in `tests/ui/<category>/` is a user mistake whose compile
//! errors are pinned in the `.stderr` beside it (`TRYBUILD=overwrite` regenerates them).

#[test]
fn ui() {
    // trybuild compiles the cases in a crate of its own; spec paths in them are relative to
    // this crate's directory (the derive's testing hook, see `lower::MANIFEST_DIR_OVERRIDE`).
    std::env::set_var("LINCAL_DERIVE_MANIFEST_DIR", env!("CARGO_MANIFEST_DIR"));
    let t = trybuild::TestCases::new();
    t.compile_fail("tests/ui/file/*.rs");
    t.compile_fail("tests/ui/inline/*.rs");
    t.compile_fail("tests/ui/attr/*.rs");
}
