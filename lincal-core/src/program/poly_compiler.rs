//! Exact polynomials compiled onto a [`Builder`]: each variable of a [`VarTable`] read as
//! an input value (`q_i`, `cos q_i`, `p_j`, …) or folded as a known number, each polynomial
//! an affine combination of shared monomial values.

use super::builder::Builder;
use super::straight_line::{LinComb, ValueId};
use crate::symbolic::coef::Coef;
use crate::symbolic::monomial::{Mono, Var, VarTable};
use crate::symbolic::poly::Poly;

/// What a polynomial variable stands for in a program.
enum VarValue {
    /// A value computed from the inputs.
    Input(InputVar),
    /// A known number, folded into coefficients.
    Known(f64),
}

#[derive(Clone, Copy)]
enum InputVar {
    Q(usize),
    CosQ(usize),
    SinQ(usize),
    P(usize),
    CosP(usize),
    SinP(usize),
}

fn var_value(v: &Var) -> VarValue {
    match v {
        Var::JointCos(i) => VarValue::Input(InputVar::CosQ(*i)),
        Var::JointSin(i) => VarValue::Input(InputVar::SinQ(*i)),
        Var::JointLinear(i) => VarValue::Input(InputVar::Q(*i)),
        Var::ParamLength(j) => VarValue::Input(InputVar::P(*j)),
        Var::ParamCos(j) => VarValue::Input(InputVar::CosP(*j)),
        Var::ParamSin(j) => VarValue::Input(InputVar::SinP(*j)),
        Var::ConstCos(x, _) => VarValue::Known(x.cos()),
        Var::ConstSin(x, _) => VarValue::Known(x.sin()),
        Var::ConstLength(x, _) => VarValue::Known(*x),
    }
}

fn input_value(b: &mut Builder, iv: InputVar) -> ValueId {
    match iv {
        InputVar::Q(i) => b.q(i),
        InputVar::CosQ(i) => {
            let x = b.q(i);
            b.cos(x)
        }
        InputVar::SinQ(i) => {
            let x = b.q(i);
            b.sin(x)
        }
        InputVar::P(j) => b.p(j),
        InputVar::CosP(j) => {
            let x = b.p(j);
            b.cos(x)
        }
        InputVar::SinP(j) => {
            let x = b.p(j);
            b.sin(x)
        }
    }
}

/// Compiles exact polynomials (over a [`VarTable`]'s variables) into affine combinations of
/// shared monomial values.
pub(super) struct PolyCompiler<'a> {
    pub(super) b: Builder,
    pub(super) vars: &'a VarTable,
}

impl PolyCompiler<'_> {
    pub(super) fn term(&mut self, m: &Mono, c: &Coef, out: &mut LinComb) {
        let mut coef = c.to_f64();
        let mut input = Mono::ONE;
        for (v, e) in m.factors() {
            match var_value(&self.vars.vars[v]) {
                VarValue::Known(x) => coef *= x.powi(e as i32),
                VarValue::Input(_) => input.set(v, e),
            }
        }
        let vars = self.vars;
        let mut var = |b: &mut Builder, v: usize| match var_value(&vars.vars[v]) {
            VarValue::Input(iv) => input_value(b, iv),
            VarValue::Known(_) => unreachable!("known factors are split off above"),
        };
        match self.b.mono(&input, &mut var) {
            None => out.constant += coef,
            Some(x) => out.push(coef, x),
        }
    }

    pub(super) fn poly(&mut self, p: &Poly) -> LinComb {
        let mut out = LinComb::default();
        for (m, c) in p.sorted_terms() {
            self.term(&m, &c, &mut out);
        }
        out
    }
}
