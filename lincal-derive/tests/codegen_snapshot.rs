//! The exact code the derive emits for one small model, formatted with prettyplease and pinned
//! by an insta snapshot: any change to the engine or the printer shows up as a reviewed diff.
//!
//! `codegen.rs` depends on nothing else in the derive crate, so it is included here as a
//! module and called directly (a proc-macro crate cannot export ordinary functions).

#[allow(dead_code)]
#[path = "../src/codegen.rs"]
mod codegen;

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

#[test]
fn adept_one_generated_code() {
    let spec = lincal_core::spec::from_yaml_str(ADEPT, None).unwrap();
    let model = SymbolicModel::from_spec(&spec).unwrap();
    let program = ModelProgram::from_model(&model).unwrap();
    let ident: syn::Ident = syn::parse_quote!(AdeptOne);
    let generics = syn::Generics::default();
    let krate: syn::Path = syn::parse_quote!(::lincal_core);
    let tokens = codegen::expand(&codegen::Input {
        ident: &ident,
        generics: &generics,
        krate: &krate,
        program: &program,
        include: Some("/abs/path/specs/adept_one.yaml"),
    });
    let file: syn::File = syn::parse2(tokens).expect("the generated code parses");
    insta::assert_snapshot!(prettyplease::unparse(&file));
    // The IR, for reading next to the code.
    insta::assert_snapshot!("adept_one_program", program.to_string());
}
