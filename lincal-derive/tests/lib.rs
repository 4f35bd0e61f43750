//! lincal-derive tests (one binary): compile errors (trybuild UI tests), derived models against
//! the run-time engine, the renamed-crate path, and a snapshot of the generated code.

mod codegen_snapshot;
mod equivalence;
mod ui;
