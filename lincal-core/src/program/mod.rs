//! Straight-line programs: the numeric side of a [`SymbolicModel`] as flat, branch-free code
//! that `#[derive(CalibModel)]` prints as Rust.
//!
//! A [`Program`] is a list of single-assignment values ([`Op`]: an input `q[i]` or `p[j]`, a
//! `cos`/`sin`, a product of two values, or an affine combination of values) followed by its
//! outputs, each an affine combination ([`LinComb`]) of values. Values are hash-consed while the
//! program is built, so every `cos q_i`, `sin q_i` (and `cos p_j`, `sin p_j`) is computed once
//! and every distinct monomial once, each product built from the monomial one factor shorter
//! (so `c1*c2*s3` reuses `c1*c2`). Known values (known parameters, constants, `cos(pi/2) = 0`)
//! are folded into `f64` literals; unreachable values are dropped.
//!
//! [`ModelProgram::from_model`] builds every program a derived model needs:
//! - `basis(q)`: `Φ̃_k(q)`, `K` outputs, from the reduction's exact basis;
//! - `generalized_params(p)`: `c_{e,k}(p)`, `E·K` outputs, equation-major;
//! - `jacobian(p)`: `∂c_{e,k}/∂p_j`, `E·K·P` outputs, index `(e·K + k)·P + j`;
//! - `tip(q, p)`: the forward kinematics, a numeric product of the DH transforms straight from
//!   the spec (the same formulas as [`crate::spec::kinematics`], not the expanded polynomials);
//! - `constraint_values(p)`: every constraint's values in the canonical order of
//!   [`crate::model::geometry`], concatenated (offsets in [`Summary::constraint_offsets`]);
//!
//! and a [`Summary`] of the constants (names, sizes, identifiability, gauge). The derive does
//! no mathematics: it prints these. [`Program::eval`] interprets a program, which is how the
//! programs are tested against the run-time model.
//!
//! # Example
//! ```
//! use lincal_core::model::CalibModel;
//! use lincal_core::{program::ModelProgram, symbolic::SymbolicModel};
//! let spec = lincal_core::spec::from_yaml_str(
//!     "name: two_link\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
//!      - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.375}\n  \
//!      a2: {nominal: 0.425}\n  th1: {nominal: 0}\n  th2: {nominal: 0}\n  \
//!      b1: {nominal: -1.8}\n  b2: {nominal: -0.5}\nconstraint:\n  line: {b: [b1, b2]}\n",
//!     None,
//! )
//! .unwrap();
//! let model = SymbolicModel::from_spec(&spec).unwrap();
//! let prog = ModelProgram::from_model(&model).unwrap();
//! let q = [0.3, -0.7];
//! let mut expected = [0.0; 5];
//! model.basis(&q, &mut expected);
//! let got = prog.basis.as_ref().unwrap().eval(&q, &[]);
//! for (a, b) in got.iter().zip(&expected) {
//!     assert!((a - b).abs() < 1e-14);
//! }
//! ```
//!
//! The parts: the program types and their interpreter (`straight_line`), the hash-consing
//! builder (`builder`), exact polynomials compiled onto it (`poly_compiler`), the forward
//! kinematics and constraint values straight from the spec (`kinematics`), the constants
//! ([`Summary`]) and every program of a model together ([`ModelProgram`], `model_program`).
//!
//! [`SymbolicModel`]: crate::symbolic::SymbolicModel

mod builder;
mod kinematics;
mod model_program;
mod poly_compiler;
mod straight_line;
mod summary;

#[cfg(test)]
pub(crate) use model_program::constraint_functions;
pub use model_program::{
    ModelProgram, STRAIGHT_LINE_MAX_BASIS_TERMS, STRAIGHT_LINE_MAX_TERMS, STRAIGHT_LINE_MAX_VALUES,
};
pub use straight_line::{LinComb, Op, Program, ValueId};
pub use summary::Summary;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::constraint_function;
    use crate::model::CalibModel;
    use crate::spec::from_yaml_str;
    use crate::symbolic::SymbolicModel;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const SPECS: &[&str] = &[
        // Planar 2-link on a line (the paper's AdeptOne).
        "name: adept\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
         - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.375}\n  \
         a2: {nominal: 0.425}\n  th1: {nominal: 0}\n  th2: {nominal: 0}\n  \
         b1: {nominal: -1.8}\n  b2: {nominal: -0.5}\nconstraint:\n  line: {b: [b1, b2]}\n",
        // Spatial, modified DH, a prismatic joint, a base, a known irrational angle, a known
        // length, Hayati tilts (a parameter, a constant), a sphere.
        "name: mixed\ndim: 3\nconvention: mdh\njoints:\n  \
         - {type: revolute, a: 0, alpha: 0, d: d1, home: th1}\n  \
         - {type: revolute, a: a2, alpha: pi/2, beta: be2, home: th2}\n  \
         - {type: prismatic, a: a3, alpha: tw, theta: 0, offset: o3}\n  \
         - {type: revolute, a: 0.1, alpha: 2*pi/3, beta: 0.05, d: 0.05, home: 0.3}\n\
         tool: [tx, 0, L]\nbase: {x: bx, y: 0.2, z: 0, roll: 0, pitch: 0.1, yaw: yw}\n\
         params:\n  d1: {nominal: 0.3}\n  th1: {nominal: 0.01}\n  a2: {nominal: 0.4}\n  \
         be2: {nominal: 0.02}\n  \
         th2: {nominal: -0.02}\n  a3: {nominal: 0.05}\n  tw: {nominal: 0.7, known: true}\n  \
         o3: {nominal: 0.1}\n  tx: {nominal: 0.02}\n  L: {nominal: 0.1, known: true}\n  \
         bx: {nominal: 0.5}\n  yw: {nominal: 0.1}\n  cx: {nominal: 0.4}\n  cy: {nominal: 0.1}\n  \
         cz: {nominal: 0.2}\n  r: {nominal: 0.15}\n\
         constraint:\n  sphere: {center: [cx, cy, cz], radius: r}\n",
        // Two lines in 3-D and a point, as a list.
        "name: lines\ndim: 3\njoints:\n  - {type: revolute, a: a1, alpha: pi/2, d: d1, home: th1}\n  \
         - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.1}\n  d1: {nominal: 0.3}\n  \
         th1: {nominal: 0}\n  a2: {nominal: 0.4}\n  th2: {nominal: 0}\n  px: {nominal: 0.2}\n  \
         b1: {nominal: -1}\n  b2: {nominal: 0.5}\n\
         constraints:\n  - line: {planes: [[b1, 0, 0], [0, b2, 1]]}\n  - point: {p: [px, 0.1, 0.3]}\n",
    ];

    fn close(a: f64, b: f64, scale: f64) -> bool {
        (a - b).abs() <= 1e-12 * scale.max(1.0)
    }

    /// `c(p)` by the program, or by the factored kernel where there is none.
    fn c_of(prog: &ModelProgram, p: &[f64]) -> Vec<f64> {
        if let Some(c) = &prog.generalized_params {
            return c.eval(&[], p);
        }
        let vals = prog.constraint_values.eval(&[], p);
        let t = prog
            .factored
            .as_ref()
            .expect("the kernel's tables")
            .tables();
        let mut out = vec![0.0; t.equation_count() * t.basis_size()];
        t.generalized_params(p, &vals, &mut out);
        out
    }

    /// `∂c/∂p` by the program, or by the factored kernel where there is none.
    fn jac_of(prog: &ModelProgram, p: &[f64]) -> Vec<f64> {
        if let Some(j) = &prog.jacobian {
            return j.eval(&[], p);
        }
        let vals = prog.constraint_values.eval(&[], p);
        let tables = prog.factored.as_ref().expect("the kernel's tables");
        let t = tables.tables();
        let mut out = vec![0.0; t.equation_count() * t.basis_size() * p.len()];
        let mut scratch = vec![0.0; crate::model::factored::Tables::scratch_len(t.chain)];
        t.jacobian(p, &vals, &mut scratch, &mut out);
        out
    }

    #[test]
    fn programs_equal_the_runtime_model() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for text in SPECS {
            let spec = from_yaml_str(text, None).unwrap();
            let m = SymbolicModel::from_spec(&spec).unwrap();
            let prog = ModelProgram::from_model(&m).unwrap();
            let (n, np, k, e) = (
                m.joint_count(),
                m.param_count(),
                m.basis_size(),
                m.equation_count(),
            );
            assert_eq!(prog.summary.basis_size(), k);
            for _ in 0..20 {
                let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
                let p: Vec<f64> = (0..np).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let mut want = vec![0.0; k];
                m.basis(&q, &mut want);
                let got = prog.basis.as_ref().unwrap().eval(&q, &[]);
                for (a, b) in got.iter().zip(&want) {
                    assert!(close(*a, *b, 10.0), "{}: basis {a} vs {b}", spec.name);
                }
                let mut want = vec![0.0; e * k];
                m.generalized_params(&p, &mut want);
                let got = c_of(&prog, &p);
                for (a, b) in got.iter().zip(&want) {
                    assert!(close(*a, *b, 10.0), "{}: c {a} vs {b}", spec.name);
                }
                let mut want = vec![0.0; e * k * np];
                m.jacobian(&p, &mut want);
                let got = jac_of(&prog, &p);
                assert_eq!(got.len(), want.len());
                for (a, b) in got.iter().zip(&want) {
                    assert!(close(*a, *b, 10.0), "{}: jac {a} vs {b}", spec.name);
                }
                let mut want = vec![0.0; m.dim()];
                m.tip(&q, &p, &mut want);
                let tip = prog.tip.eval(&q, &p);
                for (a, b) in tip.iter().zip(&want) {
                    assert!(close(*a, *b, 1.0), "{}: tip {a} vs {b}", spec.name);
                }
                let vals = prog.constraint_values.eval(&[], &p);
                for j in 0..m.constraint_count() {
                    let o = &prog.summary.constraint_offsets;
                    let mut want = vec![0.0; o[j + 1] - o[j]];
                    m.constraint_values(j, &p, &mut want);
                    assert_eq!(&vals[o[j]..o[j + 1]], &want[..]);
                    // basis·c equals the direct constraint function of the tip.
                    let kind = m.constraint_kind(j);
                    let mut h = vec![0.0; kind.equation_count(m.dim())];
                    constraint_function(kind, m.dim(), &want, &tip, &mut h);
                    let phi = prog.basis.as_ref().unwrap().eval(&q, &[]);
                    let cc = c_of(&prog, &p);
                    let eqs: Vec<usize> =
                        (0..e).filter(|&x| m.equation_constraint(x) == j).collect();
                    for (hi, &eq) in h.iter().zip(&eqs) {
                        let terms: Vec<f64> = (0..k).map(|kk| cc[eq * k + kk] * phi[kk]).collect();
                        let sum: f64 = terms.iter().sum();
                        let scale: f64 = terms.iter().map(|x| x.abs()).sum();
                        assert!(close(sum, *hi, scale), "{}: h {sum} vs {hi}", spec.name);
                    }
                }
            }
        }
    }

    #[test]
    fn shares_trig_and_monomials() {
        let spec = from_yaml_str(SPECS[0], None).unwrap();
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let prog = ModelProgram::from_model(&m).unwrap();
        // Two joints: cos and sin of each, once.
        let basis = prog.basis.as_ref().unwrap();
        assert_eq!(basis.op_counts().0, 4);
        // No value is computed twice.
        for (i, a) in basis.ops.iter().enumerate() {
            assert!(!basis.ops[..i].contains(a), "{a:?} twice");
        }
        let text = basis.to_string();
        assert!(text.contains("cos(v0)"), "{text}");
    }

    #[test]
    fn known_right_angles_fold_away() {
        let spec = from_yaml_str(SPECS[2], None).unwrap();
        let m = SymbolicModel::from_spec(&spec).unwrap();
        let prog = ModelProgram::from_model(&m).unwrap();
        // alpha = pi/2 is exact: no cos/sin of a constant survives; the tip needs cos/sin
        // of the two joint angles only.
        assert_eq!(prog.tip.op_counts().0, 4, "{}", prog.tip);
    }

    /// URDF-native rows of a 7-joint arm (`tests/large/iiwa14_urdf_native.yaml`): the basis
    /// from span-equivalent links, no exact `c(p)`, so the derive's program evaluates `c` and
    /// `∂c/∂p` with the kernel, after checking `Σ c·Φ̃` against the numeric chain; the tables
    /// give the run-time model's values.
    #[test]
    fn a_basis_from_span_equivalent_links_derives_with_the_kernel() {
        let spec = crate::symbolic::testutil::repo_spec("tests/large/iiwa14_urdf_native.yaml");
        let m = SymbolicModel::from_spec(&spec).unwrap();
        assert_eq!(m.basis_size(), 2187);
        assert!(m.generalized_param_strings().is_none());
        let prog = ModelProgram::from_model(&m).unwrap();
        assert!(prog.generalized_params.is_none() && prog.jacobian.is_none());
        let t = prog.factored.as_ref().unwrap();
        let (k, e, np) = (m.basis_size(), m.equation_count(), m.param_count());
        let p: Vec<f64> = (0..np).map(|j| m.param_nominal(j) + 0.01).collect();
        let vals = crate::symbolic::factored::kernel_values(&m, t, &p);
        let (mut a, mut b) = (vec![0.0; e * k], vec![0.0; e * k]);
        m.generalized_params(&p, &mut a);
        t.tables().generalized_params(&p, &vals, &mut b);
        assert_eq!(a, b);
        assert!(a.iter().any(|x| *x != 0.0));
        // Tables with two pivots' basis functions swapped fail the derive's check.
        let mut wrong = t.clone();
        wrong.pivot_basis.swap(1, 2);
        assert!(model_program::check_identity(&m, &wrong).is_err());
    }

    /// Every spec of the repository (the test set, the large chains, the model library, the
    /// bench's and the examples' specs, and the reference cases beside the repository) has
    /// factored tables that pass the derive's check: the kernel's `c(p)` and `∂c/∂p` equal the
    /// exact ones compiled from the flat expansion where it was built, and elsewhere (a basis
    /// of grid monomials proven without it, or from span-equivalent links) `Σ c·Φ̃` equals
    /// the numeric chain's constraint functions and `∂c/∂p` the differences of `c`. Each
    /// check is also shown to fail on tables with two basis functions swapped.
    #[test]
    fn every_repository_spec_passes_the_derive_check() {
        let paths = crate::symbolic::testutil::every_repo_spec_path();
        let (mut exact, mut identity) = (0, 0);
        for name in &paths {
            let spec = crate::symbolic::testutil::repo_spec(name);
            let m = SymbolicModel::from_spec(&spec).unwrap_or_else(|e| panic!("{name}: {e}"));
            let t = m.factored().unwrap_or_else(|e| panic!("{name}: {e}"));
            model_program::check_factored(&m, &t).unwrap_or_else(|e| panic!("{name}: {e}"));
            if m.c_is_exact() {
                exact += 1;
            } else {
                identity += 1;
            }
            if m.basis_size() > 2 {
                let mut wrong = t.clone();
                wrong.pivot_basis.swap(1, 2);
                assert!(
                    model_program::check_factored(&m, &wrong).is_err(),
                    "{name}: swapped tables pass"
                );
            }
        }
        assert!(
            exact >= 30 && identity >= 8,
            "{exact} exact, {identity} by the chain"
        );
    }
}
