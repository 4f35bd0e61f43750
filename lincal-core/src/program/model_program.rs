//! [`ModelProgram`]: every program a derived model needs (`basis`, `generalized_params`,
//! `jacobian`, `tip`, `constraint_values`) and its [`Summary`], built from a
//! [`SymbolicModel`], and printed one program under another.

use std::fmt;

use super::builder::Builder;
use super::kinematics::{constraint_program, tip_program};
use super::poly_compiler::PolyCompiler;
use super::straight_line::{LinComb, Program};
use super::summary::Summary;
use crate::symbolic::SymbolicModel;

/// Every program of a derived model, and its constants.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelProgram {
    /// The constants.
    pub summary: Summary,
    /// `Φ̃(q)`: `K` outputs, reads `q`.
    pub basis: Program,
    /// `c(p)`: `E·K` outputs, equation-major, reads `p`.
    pub generalized_params: Program,
    /// `∂c/∂p`: `E·K·P` outputs at `(e·K + k)·P + j`, reads `p`.
    pub jacobian: Program,
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

        // Φ̃(q).
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
        let basis = pc.b.finish(outputs);

        // c(p).
        let mut pc = PolyCompiler {
            b: Builder::default(),
            vars,
        };
        let outputs = red.c.iter().flatten().map(|p| pc.poly(p)).collect();
        let generalized_params = pc.b.finish(outputs);

        // ∂c/∂p.
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
        let jacobian = pc.b.finish(outputs);

        let spec = model.spec();
        Ok(ModelProgram {
            summary: Summary::from_model(model),
            basis,
            generalized_params,
            jacobian,
            tip: tip_program(spec),
            constraint_values: constraint_program(spec),
        })
    }
}

impl fmt::Display for ModelProgram {
    /// Every program, each under a heading (`# basis(q)`, ...).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let parts = [
            ("basis(q)", &self.basis),
            ("generalized_params(p)", &self.generalized_params),
            ("jacobian(p)", &self.jacobian),
            ("tip(q, p)", &self.tip),
            ("constraint_values(p)", &self.constraint_values),
        ];
        for (i, (name, p)) in parts.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            writeln!(f, "# {name}")?;
            write!(f, "{p}")?;
        }
        Ok(())
    }
}
