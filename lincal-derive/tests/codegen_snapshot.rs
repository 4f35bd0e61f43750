//! The exact code the derive emits for two small models (a planar line, a measured pose),
//! formatted with prettyplease and pinned
//! by an insta snapshot: any change to the engine or the printer shows up as a reviewed diff.
//!
//! `codegen.rs` depends on nothing else in the derive crate, so it is included here as a
//! module and called directly (a proc-macro crate cannot export ordinary functions).

#[allow(dead_code)]
#[path = "../src/codegen.rs"]
mod codegen;

use lincal_core::model::CalibModel as _;
use lincal_core::program::ModelProgram;
use lincal_core::symbolic::SymbolicModel;

const ADEPT: &str = "
name: adept_one
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-2.618, 2.618]}
  - {type: revolute, a: a2, home: th2, limits: [-2.566, 2.566]}
params:
  a1: {nominal: 0.375}
  th1: {nominal: 0.0}
  a2: {nominal: 0.425}
  th2: {nominal: 0.0}
  b1: {nominal: -1.793347906344996}
  b2: {nominal: -0.5611055031089204}
constraint:
  line: {b: [b1, b2]}
";

/// The derive's output for `program`, as tokens, the type named `name`.
fn generate(
    program: &ModelProgram,
    name: &str,
    include: Option<&str>,
    orientation_weight: Option<f64>,
) -> proc_macro2::TokenStream {
    let ident = syn::Ident::new(name, proc_macro2::Span::call_site());
    let generics = syn::Generics::default();
    let krate: syn::Path = syn::parse_quote!(::lincal_core);
    codegen::expand(&codegen::Input {
        ident: &ident,
        generics: &generics,
        krate: &krate,
        program,
        include,
        orientation_weight,
    })
}

#[test]
fn adept_one_generated_code() {
    let spec = lincal_core::spec::from_yaml_str(ADEPT, None).unwrap();
    let model = SymbolicModel::from_spec(&spec).unwrap();
    let program = ModelProgram::from_model(&model).unwrap();
    let tokens = generate(
        &program,
        "AdeptOne",
        Some("/abs/path/specs/adept_one.yaml"),
        None,
    );
    let file: syn::File = syn::parse2(tokens).expect("the generated code parses");
    insta::assert_snapshot!(prettyplease::unparse(&file));
    // The IR, for reading next to the code.
    insta::assert_snapshot!("adept_one_program", program.to_string());
}

/// A two-joint spatial arm whose tool frame's pose is measured, with the noise levels stated:
/// the tool frame's rotation factors in the chain, the 12 equations (3 coordinates, 9
/// rotation entries column-major) and `orientation_weight()`.
const WRIST_POSE: &str = "
name: wrist_pose
dim: 3
joints:
  - {type: revolute, a: a1, alpha: pi/2, home: th1}
  - {type: revolute, a: a2, home: th2}
tool: {x: tx, z: 0.1, yaw: tw}
params:
  a1: {nominal: 0.3}
  th1: {nominal: 0.0}
  a2: {nominal: 0.2}
  th2: {nominal: 0.0}
  tx: {nominal: 0.05}
  tw: {nominal: 0.1}
constraint:
  measured_pose: {position_std: 2.0e-5, orientation_std: 5.0e-5}
";

#[test]
fn wrist_pose_generated_code() {
    use lincal_core::model::CalibModel as _;
    let spec = lincal_core::spec::from_yaml_str(WRIST_POSE, None).unwrap();
    let model = SymbolicModel::from_spec(&spec).unwrap();
    let program = ModelProgram::from_model(&model).unwrap();
    let tokens = generate(
        &program,
        "WristPose",
        None,
        Some(model.orientation_weight()),
    );
    let code = prettyplease::unparse(&syn::parse2(tokens).expect("the generated code parses"));
    assert!(code.contains("fn orientation_weight(&self) -> f64"));
    insta::assert_snapshot!(code);
    insta::assert_snapshot!("wrist_pose_program", program.to_string());
}

/// Every spec of the model library derives to under 200 KB of Rust (issue 48's bound: the
/// kernel and its tables replace straight-line code that grew with `K` times the
/// parameters). Prints each model's size and the engine's time, for BENCHMARKS.md
/// (`cargo test --release -p lincal-derive --test lib generated_size -- --nocapture`).
#[test]
fn generated_size_of_every_library_model() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../lincal-models/specs");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "yaml"))
        .collect();
    files.sort();
    assert!(files.len() >= 17);
    for path in files {
        let clock = std::time::Instant::now();
        let spec = lincal_core::spec::from_yaml_file(&path).unwrap();
        let model = SymbolicModel::from_spec(&spec).unwrap();
        let program = ModelProgram::from_model(&model).unwrap();
        let tokens = generate(&program, "Model", None, None);
        let bytes = tokens.to_string().len();
        let took = clock.elapsed();
        let ops = |p: &Option<lincal_core::program::Program>| {
            p.as_ref().map_or(0, |p| p.ops.len() + p.outputs.len())
        };
        println!(
            "{:28} K = {:5}  {:7} bytes  {:6.3} s  values {}/{}/{} (basis {}, c {})",
            spec.name,
            model.basis_size(),
            bytes,
            took.as_secs_f64(),
            ops(&program.basis),
            ops(&program.generalized_params),
            ops(&program.jacobian),
            if program.basis.is_some() {
                "straight-line"
            } else {
                "kernel"
            },
            if program.generalized_params.is_some() {
                "straight-line"
            } else {
                "kernel"
            },
        );
        assert!(
            bytes < 200_000,
            "{}: {bytes} bytes of generated Rust",
            spec.name
        );
    }
}
