//! # `#[derive(CalibModel)]`
//!
//! A robot calibration model, checked and expanded when the crate compiles. The derive reads a
//! spec (a YAML file, or the same content written in the attribute), runs the same exact
//! symbolic engine as `lincal basis` (expansion of the Denavit-Hartenberg chain, column
//! reduction to the basis `Φ̃(q)` and generalized parameters `c(p)`, identifiability), and
//! prints the result as Rust that runs in `#![no_std]` firmware (no allocation, only `core`
//! and `libm`): plain straight-line code where the model is small (each sin/cos and each
//! product computed once), and beyond a few thousand values the chain-factored tables (the
//! pivots and the basis's terms, one code per joint) read by the core's kernel
//! `lincal_core::model::factored`, so the generated code stays under 200 KB for any arm of the
//! model library (a 7R arm with all 28 DH parameters unknown, `K` = 2187, included). Before
//! printing, the tables are proven: `Σ_k c_k(p)·Φ̃_k(q)` equals the chain's constraint
//! functions, and `Σ_k ∂c_k/∂p·Φ̃_k(q)` their gradients, exactly modulo `2⁶¹ − 1` at random
//! points, with the kernel's own code (`lincal_core::symbolic::certify`, wrong tables passing
//! with probability below `10⁻³⁰`); its `f64` form is then checked against the exact `c(p)`
//! and `∂c/∂p` at three points.
//!
//! ## From a YAML file
//! ```ignore
//! use lincal_derive::CalibModel;
//!
//! #[derive(CalibModel)]
//! #[calib(spec = "specs/adept_one.yaml")] // relative to the crate's Cargo.toml directory
//! pub struct AdeptOne;
//!
//! let phi = AdeptOne::basis(&[0.3, -0.2]);            // Φ̃(q), [f64; AdeptOne::BASIS_SIZE]
//! let c = AdeptOne::generalized_params(&AdeptOne::NOMINALS);
//! ```
//! The file is part of the build (`include_str!`): editing it rebuilds the crate. A problem in
//! the file is a compile error on the path string naming the file, line and field, e.g.
//! `specs/adept_one.yaml:9:5: field `params.a1`: parameter `a1` is never used in a slot`.
//!
//! ## Inline
//! Everything the YAML can say, as attribute items (several `#[calib(...)]` attributes are
//! merged):
//!
//! | YAML | inline |
//! |---|---|
//! | `name: two_link` | `name = "two_link"` (default: the type's name in snake_case) |
//! | `description: ...` | `description = "..."` |
//! | `dim: 2` | `dim = 2` |
//! | `convention: mdh` | `convention = mdh` (default `dh`) |
//! | `joints: [{type: revolute, a: a1, home: th1, limits: [-2, 2]}]` | `joint(revolute, a = a1, home = th1, limits = [-2, 2])`, one per joint, base to tip |
//! | `{type: prismatic, alpha: pi/2, theta: 0, offset: d3}` | `joint(prismatic, alpha = pi/2, theta = 0, offset = d3)` |
//! | `tool: [0, 0, 0.1]` | `tool = [0, 0, 0.1]` |
//! | `tool: {x: tx, z: 0.1, roll: tr, yaw: pi/2}` (a tool frame) | `tool(x = tx, z = 0.1, roll = tr, yaw = pi/2)` |
//! | `base: {x: 0.1, yaw: pi/2}` | `base(x = 0.1, yaw = pi/2)` |
//! | `params: {a1: {nominal: 0.375}}` | `param(a1 = 0.375)`, or several: `params(a1 = 0.375, a2 = 0.425)` |
//! | `r: {nominal: 0.15, known: true}` | `param(r = 0.15, known)`, or several: `known(r = 0.15, L = 0.1)` |
//! | `constraint: {line: {b: [b1, b2]}}` | `constraint(line(b = [b1, b2]))` |
//! | `constraints: [{line: ..}, {point: ..}]` | `constraints(line(b = [b1, b2]), point(p = [px, py]))` |
//!
//! Constraint kinds: `point(p = [..])`, `line(b = [b1, b2])` (dim 2),
//! `line(planes = [[..3], [..3]])` (dim 3), `plane(b = [..3])` or
//! `plane(normal = [..3], offset = d)` (`n·x = d`, also through the origin),
//! `circle(center = [..2], radius = r)`, `sphere(center = [..3], radius = r)`,
//! `quadric(A = [[..], ..], b = [..])`, `measured`, `measured_pose` (the tool frame's position
//! and orientation measured; dim 3) or `measured_pose(position_std = 2e-5, orientation_std =
//! 5e-5)` (the noise levels, metres and radians, each optional). With `measured_pose` the tool
//! may be a frame, `tool(x, y, z, roll, pitch, yaw)` (each entry a slot, missing ones 0;
//! `Rz(yaw)·Ry(pitch)·Rx(roll)` after the translation, as `base`).
//!
//! A slot is a number (`0.375`, `-1`), an exact expression (`pi/2`, `-pi/2`, `2*pi/3`), or a
//! parameter name, bare (`a1`) or quoted (`"a1"`). Nominal values are numbers or expressions.
//! Numbers stay exact (`0.1` is 1/10, `cos(pi/2)` is 0), as in the YAML.
//!
//! ```
//! use lincal_derive::CalibModel;
//!
//! /// The paper's AdeptOne experiment: a planar 2-link arm, tip on an unknown line.
//! #[derive(CalibModel)]
//! #[calib(
//!     dim = 2,
//!     joint(revolute, a = a1, home = th1, limits = [-2.618, 2.618]),
//!     joint(revolute, a = a2, home = th2),
//!     params(a1 = 0.375, th1 = 0, a2 = 0.425, th2 = 0, b1 = -1.79, b2 = -0.56),
//!     constraint(line(b = [b1, b2])),
//! )]
//! pub struct TwoLink;
//!
//! assert_eq!(TwoLink::NAME, "two_link");
//! assert_eq!(TwoLink::BASIS_SIZE, 5); // 1, c1, s1, c1*c2 - s1*s2, c1*s2 + s1*c2
//! assert_eq!(TwoLink::IDENTIFIABLE_COUNT, 4);
//! // On the constraint at the nominal parameters, h = c(p)·Φ̃(q) vanishes.
//! let p = TwoLink::NOMINALS;
//! let q = [0.4, 0.0];
//! let tip = TwoLink::tip(&q, &p);
//! let h = TwoLink::equations(&q, &p)[0];
//! assert!((h - (-1.79 * tip[0] - 0.56 * tip[1] + 1.0)).abs() < 1e-12);
//!
//! // The same model through the trait the solver takes.
//! use lincal_core::model::CalibModel as _;
//! let m: &dyn lincal_core::model::CalibModel = &TwoLink;
//! assert_eq!(m.basis_size(), 5);
//! ```
//!
//! A mistake is a compile error at the token that holds it (`unknown key `hom` in a joint (did
//! you mean `home`?)`, `` `b3` is not a parameter ``, `` `plane` is a 3-D constraint ``), every
//! mistake at once; beside the errors the derive emits a stub impl so that the errors are not
//! followed by a cascade.
//!
//! ## What is generated
//! Inherent constants `NAME`, `DIM`, `JOINTS`, `PARAMS`, `BASIS_SIZE`, `NAIVE_SIZE`,
//! `EQUATIONS`, `IDENTIFIABLE_COUNT`, `PARAM_NAMES`, `NOMINALS`, `BASIS_NAMES`,
//! `IDENTIFIABLE`, `HELD`, `GAUGE`; inherent functions `basis(q)`, `generalized_params(p)`,
//! `jacobian(p)`, `tip(q, p)`, `constraint_values(p)`, `equations(q, p)` on fixed-size arrays;
//! and `impl lincal_core::model::CalibModel`, which the solver, extraction and refinement take.
//! For `measured_pose`, the equations are the tool frame's origin and its rotation's 9 entries
//! (column-major), the trait's `tool_pose(q, p, ..)` gives the whole frame, and when the spec
//! states both noise levels `orientation_weight()` returns `position_std / orientation_std`
//! (otherwise the trait's default, and the calibration estimates the ratio from the data).
//! Everything is inside `const _: () = { ... };` and reaches the runtime only through
//! `::lincal_core::__private`; a crate that re-exports lincal-core under another path says
//! so with `#[calib(crate = "::my_crate::lincal_core")]`.
#![warn(missing_docs)]

extern crate proc_macro;

mod ast;
mod attr;
mod codegen;
mod ctxt;
mod fallback;
mod lower;
mod tree;

#[cfg(test)]
mod equivalence;

use proc_macro::TokenStream;
use syn::{parse_macro_input, DeriveInput};

/// Derives a calibration model from `#[calib(...)]`; see the crate documentation.
#[proc_macro_derive(CalibModel, attributes(calib))]
pub fn derive_calib_model(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    let cx = ctxt::Ctxt::new();
    let container = ast::Container::from_ast(&input, &cx);
    let lowered = if cx.has_errors() {
        None
    } else {
        lower::lower(&container, &cx)
    };
    let krate = container
        .attrs
        .krate
        .clone()
        .unwrap_or_else(|| syn::parse_quote!(::lincal_core));
    match (cx.check(), lowered) {
        (Ok(()), Some(l)) => codegen::expand(&codegen::Input {
            ident: &container.ident,
            generics: &container.generics,
            krate: &krate,
            program: &l.program,
            include: l.include.as_deref(),
            orientation_weight: l.orientation_weight,
        })
        .into(),
        (Err(errors), _) => {
            fallback::expand(&container.ident, &container.generics, &krate, &errors).into()
        }
        (Ok(()), None) => {
            let errors = syn::Error::new_spanned(&container.ident, "the model could not be built");
            fallback::expand(&container.ident, &container.generics, &krate, &errors).into()
        }
    }
}
