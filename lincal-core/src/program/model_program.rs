//! [`ModelProgram`]: every program a derived model needs (`basis`, `generalized_params`,
//! `jacobian`, `tip`, `constraint_values`) and its [`Summary`], built from a
//! [`SymbolicModel`], and printed one program under another.

use std::fmt;

use super::builder::Builder;
use super::kinematics::{constraint_program, tip_program};
use super::poly_compiler::PolyCompiler;
use super::straight_line::{LinComb, Program};
use super::summary::Summary;
use crate::symbolic::factored::FactoredTables;
use crate::symbolic::SymbolicModel;
use crate::symbolic::{monomial::VarTable, reduce::Reduction};

/// The most terms (all of `c(p)`'s exact polynomials together) for which `c(p)` and
/// `∂c/∂p` are built as straight-line programs; beyond it the derived model evaluates them
/// with the factored kernel ([`crate::model::factored`]), whose code does not grow with the
/// model.
pub const STRAIGHT_LINE_MAX_TERMS: usize = 2_000;

/// The most values (operations and outputs) of `c(p)`, and apart of `∂c/∂p`, that are
/// printed as straight-line code (about 30 bytes of Rust each): beyond it, the kernel. At
/// 2 500 the PUMA on a sphere (2 961 values) fell to the kernel, whose degree-two passes made
/// its `c(p)` 16× slower than the run-time model's polynomials; at 3 000 it is printed, and
/// every library model stays under 200 KB of generated Rust.
pub const STRAIGHT_LINE_MAX_VALUES: usize = 3_000;

/// The most terms of `R` (the basis functions over the monomials) for which `Φ̃(q)` is printed
/// as straight-line code (each product once); beyond it the kernel's trie evaluates it.
pub const STRAIGHT_LINE_MAX_BASIS_TERMS: usize = 1_500;

/// Every program of a derived model, and its constants.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelProgram {
    /// The constants.
    pub summary: Summary,
    /// `Φ̃(q)`: `K` outputs, reads `q`; `None` where the kernel evaluates it (more than
    /// [`STRAIGHT_LINE_MAX_BASIS_TERMS`] terms).
    pub basis: Option<Program>,
    /// `c(p)`: `E·K` outputs, equation-major, reads `p`; `None` where the kernel evaluates it
    /// (more than [`STRAIGHT_LINE_MAX_TERMS`] terms, or more than
    /// [`STRAIGHT_LINE_MAX_VALUES`] values).
    pub generalized_params: Option<Program>,
    /// `∂c/∂p`: `E·K·P` outputs at `(e·K + k)·P + j`, reads `p`; `None` where the kernel
    /// evaluates it (more than [`STRAIGHT_LINE_MAX_TERMS`] terms in `c`, or more than
    /// [`STRAIGHT_LINE_MAX_VALUES`] values).
    pub jacobian: Option<Program>,
    /// The chain-factored tables the kernel evaluates beyond the straight-line bounds;
    /// `None` where every program is straight-line and the chain is one the kernel does not
    /// hold (more than [`crate::model::factored::MAX_JOINTS`] joints).
    pub factored: Option<FactoredTables>,
    /// The tip `x(q; p)`: `dim` outputs.
    pub tip: Program,
    /// Every constraint's values, concatenated (see [`Summary::constraint_offsets`]).
    pub constraint_values: Program,
}

impl ModelProgram {
    /// Builds every program of `model`.
    ///
    /// # Errors
    /// The exact `∂c/∂p` cannot be represented (a derivative whose degree overflows the monomial encoding).
    pub fn from_model(model: &SymbolicModel) -> crate::error::Result<Self> {
        model.exact_polynomials()?;
        let vars = &model.expansion()?.vars;
        let red = model.reduction()?;
        // The kernel's tables, checked against the exact polynomials; a chain it does not
        // hold is an error only where a program needs it (below).
        let factored = match model.factored() {
            Ok(t) => {
                check_factored(model, &t)?;
                Ok(t)
            }
            Err(e) => Err(e),
        };

        let basis = straight_line_basis(red, vars);
        let (generalized_params, jacobian) = straight_line_c(model, red, vars)?;

        let spec = model.spec();
        let needed = basis.is_none() || generalized_params.is_none() || jacobian.is_none();
        let factored = match factored {
            Ok(t) => Some(t),
            Err(e) if needed => return Err(e),
            Err(_) => None,
        };
        Ok(ModelProgram {
            summary: Summary::from_model(model),
            basis,
            generalized_params,
            jacobian,
            factored,
            tip: tip_program(spec),
            constraint_values: constraint_program(spec),
        })
    }
}

/// `Φ̃(q)` as straight-line code, up to [`STRAIGHT_LINE_MAX_BASIS_TERMS`] terms of `R`.
fn straight_line_basis(red: &Reduction, vars: &VarTable) -> Option<Program> {
    let basis_terms: usize = red.basis.iter().map(Vec::len).sum();
    (basis_terms <= STRAIGHT_LINE_MAX_BASIS_TERMS).then(|| {
        let mut pc = PolyCompiler {
            b: Builder::default(),
            vars,
        };
        let outputs = red
            .basis
            .iter()
            .map(|terms| {
                let mut out = LinComb::default();
                for (m, c) in terms {
                    pc.term(m, c, &mut out);
                }
                out
            })
            .collect();
        pc.b.finish(outputs)
    })
}

/// `c(p)` and `∂c/∂p` as straight-line code, each kept when it has at most
/// [`STRAIGHT_LINE_MAX_VALUES`] values (built only up to [`STRAIGHT_LINE_MAX_TERMS`] terms of
/// `c`).
fn straight_line_c(
    model: &SymbolicModel,
    red: &Reduction,
    vars: &VarTable,
) -> crate::error::Result<(Option<Program>, Option<Program>)> {
    let c_terms: usize = red.c.iter().flatten().map(|p| p.len()).sum();
    // A basis from span-equivalent links has no exact `c(p)` to print: the kernel's.
    if c_terms > STRAIGHT_LINE_MAX_TERMS || !model.c_is_exact() {
        return Ok((None, None));
    }
    let small = |p: Program| {
        let size = p.ops.len() + p.outputs.iter().filter(|o| !o.is_zero()).count();
        (size <= STRAIGHT_LINE_MAX_VALUES).then_some(p)
    };
    let mut pc = PolyCompiler {
        b: Builder::default(),
        vars,
    };
    let outputs = red.c.iter().flatten().map(|p| pc.poly(p)).collect();
    let generalized_params = small(pc.b.finish(outputs));
    let mut pc = PolyCompiler {
        b: Builder::default(),
        vars,
    };
    let outputs = model
        .jacobian_polys()?
        .iter()
        .flatten()
        .flatten()
        .map(|p| pc.poly(p))
        .collect();
    Ok((generalized_params, small(pc.b.finish(outputs))))
}

impl fmt::Display for ModelProgram {
    /// Every program, each under a heading (`# basis(q)`, ...).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts = [
            ("basis(q)", self.basis.as_ref()),
            ("generalized_params(p)", self.generalized_params.as_ref()),
            ("jacobian(p)", self.jacobian.as_ref()),
            ("tip(q, p)", Some(&self.tip)),
            ("constraint_values(p)", Some(&self.constraint_values)),
        ];
        for (i, (name, p)) in parts.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            writeln!(f, "# {name}")?;
            match p {
                Some(p) => write!(f, "{p}")?,
                None => writeln!(f, "(the factored kernel, from the tables)")?,
            }
        }
        Ok(())
    }
}

/// The factored tables `t` proven against the model first ([`SymbolicModel::certify_factored`]:
/// `Σ c·Φ̃ = h` exactly modulo a prime at random points, the kernel's contraction run in the
/// field); then the kernel's `f64` code against the exact `c(p)` and `∂c/∂p` (compiled from the
/// exact polynomials) at three random parameter vectors near the nominals, relative tolerance
/// 1e-9, or where `c(p)` has none, [`check_identity`]. A derived model whose tables fail
/// either does not build.
pub(super) fn check_factored(
    model: &SymbolicModel,
    t: &FactoredTables,
) -> crate::error::Result<()> {
    use crate::model::CalibModel as _;
    let (k, e, np) = (
        model.basis_size(),
        model.equation_count(),
        model.param_count(),
    );
    // The proof first; the comparisons below check the kernel's f64 code and `∂c/∂p`.
    model.certify_factored(t, true)?;
    if !model.c_is_exact() {
        return check_identity(model, t);
    }
    let tables = t.tables();
    let mut scratch = vec![0.0; crate::model::factored::Tables::scratch_len(&t.chain)];
    let (mut c0, mut c1) = (vec![0.0; e * k], vec![0.0; e * k]);
    let (mut j0, mut j1) = (vec![0.0; e * k * np], vec![0.0; e * k * np]);
    let mut next = sequence();
    for _ in 0..3 {
        let p: Vec<f64> = (0..np)
            .map(|j| model.param_nominal(j) + 0.2 * next())
            .collect();
        let mut vals = vec![0.0; t.offsets.last().copied().unwrap_or(0)];
        for j in 0..model.constraint_count() {
            model.constraint_values(j, &p, &mut vals[t.offsets[j]..t.offsets[j + 1]]);
        }
        model.generalized_params(&p, &mut c0);
        tables.generalized_params(&p, &vals, &mut c1);
        model.jacobian(&p, &mut j0);
        tables.jacobian(&p, &vals, &mut scratch, &mut j1);
        for (what, a, b) in [("c(p)", &c0, &c1), ("∂c/∂p", &j0, &j1)] {
            let scale = a.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            if let Some(i) = (0..a.len()).find(|&i| (a[i] - b[i]).abs() > 1e-9 * scale) {
                return Err(crate::error::Error::other(format!(
                    "the factored model disagrees with the exact {what} at entry {i} ({} against \
                     {}): an engine bug, please report it with the spec",
                    b[i], a[i]
                )));
            }
        }
    }
    Ok(())
}

/// A fixed pseudo-random sequence in `[-0.5, 0.5)` (the build stays deterministic).
fn sequence() -> impl FnMut() -> f64 {
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// For a model whose `c(p)` only the kernel gives (a basis from span-equivalent links, no
/// exact polynomials), the tables `t` the derived model embeds, their `c` and their `Φ̃`:
/// `h_e(q; p) = Σ_k c_{e,k}(p)·Φ̃_k(q)`
/// against the constraint functions of the numeric chain ([`constraint_functions`]) at three
/// parameter vectors near the nominals and four readings each, relative tolerance 1e-9; and
/// `∂c/∂p` against central differences of `c` (step 1e-6, relative 1e-6) at the first.
pub(super) fn check_identity(
    model: &SymbolicModel,
    t: &FactoredTables,
) -> crate::error::Result<()> {
    use crate::model::CalibModel as _;
    let (k, e, np, n) = (
        model.basis_size(),
        model.equation_count(),
        model.param_count(),
        model.joint_count(),
    );
    let tables = t.tables();
    let kernel_c = |p: &[f64], out: &mut [f64]| {
        let vals = crate::symbolic::factored::kernel_values(model, t, p);
        tables.generalized_params(p, &vals, out);
    };
    let bug = |what: String| {
        Err(crate::error::Error::other(format!(
            "the factored model disagrees with {what}: an engine bug, please report it with the \
             spec"
        )))
    };
    let mut next = sequence();
    let (mut c, mut phi) = (vec![0.0; e * k], vec![0.0; k]);
    for round in 0..3 {
        let p: Vec<f64> = (0..np)
            .map(|j| model.param_nominal(j) + 0.2 * next())
            .collect();
        kernel_c(&p, &mut c);
        for _ in 0..4 {
            let q: Vec<f64> = (0..n).map(|_| 6.0 * next()).collect();
            tables.basis(&q, &mut phi);
            let h = constraint_functions(model, &q, &p);
            for (eq, &want) in h.iter().enumerate() {
                let terms = (0..k).map(|kk| c[eq * k + kk] * phi[kk]);
                let (sum, scale) = terms.fold((0.0, want.abs()), |(s, a), x| (s + x, a + x.abs()));
                if (sum - want).abs() > 1e-9 * scale.max(1.0) || !sum.is_finite() {
                    return bug(format!("the chain at equation {eq} ({sum} against {want})"));
                }
            }
        }
        if round > 0 {
            continue;
        }
        let vals = crate::symbolic::factored::kernel_values(model, t, &p);
        let mut jac = vec![0.0; e * k * np];
        let mut scratch = vec![0.0; crate::model::factored::Tables::scratch_len(&t.chain)];
        tables.jacobian(&p, &vals, &mut scratch, &mut jac);
        let scale = c.iter().fold(1.0f64, |m, x| m.max(x.abs()));
        let (mut up, mut down) = (vec![0.0; e * k], vec![0.0; e * k]);
        for j in 0..np {
            let mut pj = p.clone();
            pj[j] = p[j] + 1e-6;
            kernel_c(&pj, &mut up);
            pj[j] = p[j] - 1e-6;
            kernel_c(&pj, &mut down);
            for i in 0..e * k {
                let fd = (up[i] - down[i]) / 2e-6;
                if (fd - jac[i * np + j]).abs() > 1e-6 * scale {
                    return bug(format!("differences of c(p) in ∂c/∂p at ({i}, {j})"));
                }
            }
        }
    }
    Ok(())
}

/// Every constraint function `h_e(q; p)` from the numeric chain and the geometry module,
/// independent of the symbolic engine (a measured pose's rotation entries from the tool
/// frame).
pub(crate) fn constraint_functions(
    m: &dyn crate::model::CalibModel,
    q: &[f64],
    p: &[f64],
) -> Vec<f64> {
    use crate::model::geometry::{constraint_function, ConstraintKind};
    let mut x = vec![0.0; m.dim()];
    m.tip(q, p, &mut x);
    let mut out = Vec::new();
    for j in 0..m.constraint_count() {
        let kind = m.constraint_kind(j);
        let mut vals = vec![0.0; kind.value_count(m.dim())];
        m.constraint_values(j, p, &mut vals);
        let mut h = vec![0.0; kind.equation_count(m.dim())];
        constraint_function(kind, m.dim(), &vals, &x, &mut h);
        if kind == ConstraintKind::MeasuredPose {
            let (mut t, mut rot) = ([0.0; 3], [0.0; 9]);
            m.tool_pose(q, p, &mut t, &mut rot);
            h[3..].copy_from_slice(&rot);
        }
        out.extend(h);
    }
    out
}
