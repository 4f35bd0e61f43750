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
//! let got = prog.basis.eval(&q, &[]);
//! for (a, b) in got.iter().zip(&expected) {
//!     assert!((a - b).abs() < 1e-14);
//! }
//! ```

use std::collections::HashMap;
use std::fmt;

use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::spec::{Convention, Exact, JointKind, Slot, Spec};
use crate::symbolic::coef::Coef;
use crate::symbolic::expand::ParamVars;
use crate::symbolic::monomial::{Mono, Var, VarTable};
use crate::symbolic::poly::Poly;
use crate::symbolic::SymbolicModel;

/// Index of a value in a [`Program`] (values are numbered in evaluation order).
pub type ValueId = usize;

/// One single-assignment value of a [`Program`]. Operands always precede the value.
#[derive(Clone, Debug, PartialEq)]
pub enum Op {
    /// The joint reading `q[i]`.
    Q(usize),
    /// The estimated parameter `p[j]`.
    P(usize),
    /// `cos` of a value.
    Cos(ValueId),
    /// `sin` of a value.
    Sin(ValueId),
    /// The product of two values.
    Mul(ValueId, ValueId),
    /// An affine combination of values.
    Lin(LinComb),
}

/// `constant + Σ coefficient·value`: an output, or an intermediate sum.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LinComb {
    /// `(coefficient, value)` pairs, each value at most once, none with a zero coefficient.
    pub terms: Vec<(f64, ValueId)>,
    /// The constant part.
    pub constant: f64,
}

impl LinComb {
    /// The constant `c`.
    #[must_use]
    pub fn constant(c: f64) -> Self {
        LinComb {
            terms: Vec::new(),
            constant: c,
        }
    }

    /// The value `v` itself.
    #[must_use]
    pub fn value(v: ValueId) -> Self {
        LinComb {
            terms: vec![(1.0, v)],
            constant: 0.0,
        }
    }

    /// Whether this is a constant (no value terms).
    #[must_use]
    pub fn is_constant(&self) -> bool {
        self.terms.is_empty()
    }

    /// Whether this is exactly zero.
    #[must_use]
    pub fn is_zero(&self) -> bool {
        self.terms.is_empty() && self.constant == 0.0
    }

    /// Adds `coefficient·value`, merging with an existing term of the same value.
    pub fn push(&mut self, coefficient: f64, v: ValueId) {
        if coefficient == 0.0 {
            return;
        }
        if let Some(i) = self.terms.iter().position(|t| t.1 == v) {
            self.terms[i].0 += coefficient;
            if self.terms[i].0 == 0.0 {
                self.terms.remove(i);
            }
        } else {
            self.terms.push((coefficient, v));
        }
    }

    /// `self + k·o`.
    #[must_use]
    pub fn add_scaled(&self, o: &LinComb, k: f64) -> LinComb {
        let mut r = self.clone();
        if k == 0.0 {
            return r;
        }
        r.constant += k * o.constant;
        for &(c, v) in &o.terms {
            r.push(k * c, v);
        }
        r
    }

    /// `k·self`.
    #[must_use]
    pub fn scale(&self, k: f64) -> LinComb {
        LinComb::constant(0.0).add_scaled(self, k)
    }

    /// The value, given the values computed so far.
    #[must_use]
    pub fn eval(&self, vals: &[f64]) -> f64 {
        self.terms
            .iter()
            .fold(self.constant, |acc, &(c, v)| acc + c * vals[v])
    }
}

/// A straight-line program: values in order, then outputs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    /// The values; `ops[i]` defines value `i`.
    pub ops: Vec<Op>,
    /// The outputs.
    pub outputs: Vec<LinComb>,
}

impl Program {
    /// Interprets the program (with `std`'s `cos`/`sin`) for inputs `q` and `p`.
    ///
    /// # Panics
    /// If the program reads `q[i]` or `p[j]` beyond the slices.
    #[must_use]
    pub fn eval(&self, q: &[f64], p: &[f64]) -> Vec<f64> {
        let mut vals = Vec::with_capacity(self.ops.len());
        for op in &self.ops {
            let x = match op {
                Op::Q(i) => q[*i],
                Op::P(j) => p[*j],
                Op::Cos(v) => f64::cos(vals[*v]),
                Op::Sin(v) => f64::sin(vals[*v]),
                Op::Mul(a, b) => vals[*a] * vals[*b],
                Op::Lin(l) => l.eval(&vals),
            };
            vals.push(x);
        }
        self.outputs.iter().map(|o| o.eval(&vals)).collect()
    }

    /// Number of operations of each kind: `(trig, products, sums)`.
    #[must_use]
    pub fn op_counts(&self) -> (usize, usize, usize) {
        let mut n = (0, 0, 0);
        for op in &self.ops {
            match op {
                Op::Cos(_) | Op::Sin(_) => n.0 += 1,
                Op::Mul(..) => n.1 += 1,
                Op::Lin(_) => n.2 += 1,
                Op::Q(_) | Op::P(_) => {}
            }
        }
        n
    }

    /// Whether any value reads `q`.
    #[must_use]
    pub fn reads_q(&self) -> bool {
        self.ops.iter().any(|o| matches!(o, Op::Q(_)))
    }

    /// Whether any value reads `p`.
    #[must_use]
    pub fn reads_p(&self) -> bool {
        self.ops.iter().any(|o| matches!(o, Op::P(_)))
    }
}

fn write_lin(f: &mut fmt::Formatter<'_>, l: &LinComb) -> fmt::Result {
    let mut first = true;
    for &(c, v) in &l.terms {
        let (neg, a) = (c < 0.0, c.abs());
        match (first, neg) {
            (true, true) => f.write_str("-")?,
            (true, false) => {}
            (false, true) => f.write_str(" - ")?,
            (false, false) => f.write_str(" + ")?,
        }
        if a == 1.0 {
            write!(f, "v{v}")?;
        } else {
            write!(f, "{a:?}*v{v}")?;
        }
        first = false;
    }
    if first {
        write!(f, "{:?}", l.constant)
    } else if l.constant != 0.0 {
        let sign = if l.constant < 0.0 { " - " } else { " + " };
        write!(f, "{sign}{:?}", l.constant.abs())
    } else {
        Ok(())
    }
}

impl fmt::Display for Program {
    /// One line per value (`v3 = v1*v2`), then one per output (`out[0] = 0.5*v3 - v4`).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, op) in self.ops.iter().enumerate() {
            write!(f, "v{i} = ")?;
            match op {
                Op::Q(k) => write!(f, "q[{k}]")?,
                Op::P(k) => write!(f, "p[{k}]")?,
                Op::Cos(v) => write!(f, "cos(v{v})")?,
                Op::Sin(v) => write!(f, "sin(v{v})")?,
                Op::Mul(a, b) => write!(f, "v{a}*v{b}")?,
                Op::Lin(l) => write_lin(f, l)?,
            }
            f.write_str("\n")?;
        }
        for (i, o) in self.outputs.iter().enumerate() {
            write!(f, "out[{i}] = ")?;
            write_lin(f, o)?;
            f.write_str("\n")?;
        }
        Ok(())
    }
}

/// Hash-consing key of an op (`f64`s by their bits).
#[derive(Clone, PartialEq, Eq, Hash)]
enum Key {
    Q(usize),
    P(usize),
    Cos(ValueId),
    Sin(ValueId),
    Mul(ValueId, ValueId),
    Lin(Vec<(u64, ValueId)>, u64),
}

/// Builds a [`Program`] with common values shared.
#[derive(Default)]
struct Builder {
    ops: Vec<Op>,
    memo: HashMap<Key, ValueId>,
    monos: HashMap<Mono, ValueId>,
}

impl Builder {
    fn push(&mut self, key: Key, op: Op) -> ValueId {
        if let Some(&v) = self.memo.get(&key) {
            return v;
        }
        self.ops.push(op);
        let v = self.ops.len() - 1;
        self.memo.insert(key, v);
        v
    }

    fn q(&mut self, i: usize) -> ValueId {
        self.push(Key::Q(i), Op::Q(i))
    }

    fn p(&mut self, j: usize) -> ValueId {
        self.push(Key::P(j), Op::P(j))
    }

    fn cos(&mut self, v: ValueId) -> ValueId {
        self.push(Key::Cos(v), Op::Cos(v))
    }

    fn sin(&mut self, v: ValueId) -> ValueId {
        self.push(Key::Sin(v), Op::Sin(v))
    }

    fn mul(&mut self, a: ValueId, b: ValueId) -> ValueId {
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        self.push(Key::Mul(a, b), Op::Mul(a, b))
    }

    /// A value holding `l` (the value itself when `l` is one plain term).
    fn materialize(&mut self, l: &LinComb) -> ValueId {
        if l.constant == 0.0 && l.terms.len() == 1 && l.terms[0].0 == 1.0 {
            return l.terms[0].1;
        }
        let key = Key::Lin(
            l.terms.iter().map(|&(c, v)| (c.to_bits(), v)).collect(),
            l.constant.to_bits(),
        );
        self.push(key, Op::Lin(l.clone()))
    }

    // Affine-combination arithmetic with constant folding.

    fn add(&mut self, a: &LinComb, b: &LinComb) -> LinComb {
        a.add_scaled(b, 1.0)
    }

    fn times(&mut self, a: &LinComb, b: &LinComb) -> LinComb {
        if a.is_constant() {
            return b.scale(a.constant);
        }
        if b.is_constant() {
            return a.scale(b.constant);
        }
        // Scalar factors move out of the product: (2·x)·(−y) = −2·(x·y).
        let (ca, x) = self.factor(a);
        let (cb, y) = self.factor(b);
        let v = self.mul(x, y);
        LinComb {
            terms: vec![(ca * cb, v)],
            constant: 0.0,
        }
    }

    /// `l` as `coefficient · value`.
    fn factor(&mut self, l: &LinComb) -> (f64, ValueId) {
        if l.constant == 0.0 && l.terms.len() == 1 {
            (l.terms[0].0, l.terms[0].1)
        } else {
            (1.0, self.materialize(l))
        }
    }

    fn cos_of(&mut self, a: &LinComb) -> LinComb {
        if a.is_constant() {
            return LinComb::constant(a.constant.cos());
        }
        let x = self.materialize(a);
        LinComb::value(self.cos(x))
    }

    fn sin_of(&mut self, a: &LinComb) -> LinComb {
        if a.is_constant() {
            return LinComb::constant(a.constant.sin());
        }
        let x = self.materialize(a);
        LinComb::value(self.sin(x))
    }

    /// The value of monomial `m` (`None` for the constant monomial), each factor's value from
    /// `var`; built from `m` with one factor of its highest variable removed.
    fn mono(
        &mut self,
        m: &Mono,
        var: &mut dyn FnMut(&mut Builder, usize) -> ValueId,
    ) -> Option<ValueId> {
        if m.is_one() {
            return None;
        }
        if let Some(&v) = self.monos.get(m) {
            return Some(v);
        }
        let (v, e) = m.factors().last()?;
        let mut shorter = *m;
        shorter.set(v, e - 1);
        let x = var(self, v);
        let r = match self.mono(&shorter, var) {
            None => x,
            Some(y) => self.mul(y, x),
        };
        self.monos.insert(*m, r);
        Some(r)
    }

    /// Keeps only values the outputs reach, renumbered in order.
    fn finish(self, outputs: Vec<LinComb>) -> Program {
        let n = self.ops.len();
        let mut live = vec![false; n];
        for o in &outputs {
            for &(_, v) in &o.terms {
                live[v] = true;
            }
        }
        for i in (0..n).rev() {
            if !live[i] {
                continue;
            }
            match &self.ops[i] {
                Op::Cos(v) | Op::Sin(v) => live[*v] = true,
                Op::Mul(a, b) => {
                    live[*a] = true;
                    live[*b] = true;
                }
                Op::Lin(l) => l.terms.iter().for_each(|&(_, v)| live[v] = true),
                Op::Q(_) | Op::P(_) => {}
            }
        }
        let mut new_id = vec![usize::MAX; n];
        let mut ops = Vec::new();
        let remap_lin = |l: &LinComb, new_id: &[usize]| LinComb {
            terms: l.terms.iter().map(|&(c, v)| (c, new_id[v])).collect(),
            constant: l.constant,
        };
        for (i, op) in self.ops.into_iter().enumerate() {
            if !live[i] {
                continue;
            }
            let op = match op {
                Op::Cos(v) => Op::Cos(new_id[v]),
                Op::Sin(v) => Op::Sin(new_id[v]),
                Op::Mul(a, b) => Op::Mul(new_id[a], new_id[b]),
                Op::Lin(l) => Op::Lin(remap_lin(&l, &new_id)),
                o @ (Op::Q(_) | Op::P(_)) => o,
            };
            new_id[i] = ops.len();
            ops.push(op);
        }
        let outputs = outputs.iter().map(|o| remap_lin(o, &new_id)).collect();
        Program { ops, outputs }
    }
}

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
struct PolyCompiler<'a> {
    b: Builder,
    vars: &'a VarTable,
}

impl PolyCompiler<'_> {
    fn term(&mut self, m: &Mono, c: &Coef, out: &mut LinComb) {
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

    fn poly(&mut self, p: &Poly) -> LinComb {
        let mut out = LinComb::default();
        for (m, c) in p.sorted_terms() {
            self.term(&m, &c, &mut out);
        }
        out
    }
}

/// The constants of a model that generated code states (everything but the programs).
#[derive(Clone, Debug, PartialEq)]
pub struct Summary {
    /// The spec's name.
    pub name: String,
    /// 2 or 3.
    pub dim: usize,
    /// Per joint: prismatic.
    pub prismatic: Vec<bool>,
    /// Per joint: limits of the reading.
    pub limits: Vec<Option<[f64; 2]>>,
    /// Estimated parameter names (the vector `p`).
    pub param_names: Vec<String>,
    /// Their nominal values.
    pub param_nominals: Vec<f64>,
    /// Per parameter: an angle.
    pub param_is_angle: Vec<bool>,
    /// Per parameter: identifiable on its own.
    pub identifiable: Vec<bool>,
    /// Per parameter: held at nominal by the gauge rule.
    pub held: Vec<bool>,
    /// Number of independent identifiable combinations.
    pub identifiable_count: usize,
    /// Distinct joint monomials before reduction.
    pub naive_size: usize,
    /// Basis function names (`K` of them).
    pub basis_names: Vec<String>,
    /// Index of the constant basis function.
    pub constant_index: Option<usize>,
    /// Kind of each constraint.
    pub constraint_kinds: Vec<ConstraintKind>,
    /// `constraint_values` output range of constraint `j`: `offsets[j]..offsets[j + 1]`.
    pub constraint_offsets: Vec<usize>,
    /// Constraint of each equation.
    pub equation_constraint: Vec<usize>,
    /// Gauge directions, `(parameter name, coefficient)`.
    pub gauge: Vec<Vec<(String, f64)>>,
    /// The chain of elementary motions and each constraint value's parameter, for the exact
    /// tip Jacobian ([`crate::model::chain`]).
    pub chain: crate::spec::chain::Chain,
    /// The relations between constraints (spec `relations:`).
    pub relations: Vec<crate::model::geometry::Relation>,
}

impl Summary {
    /// Number of joints.
    #[must_use]
    pub fn joints(&self) -> usize {
        self.prismatic.len()
    }

    /// Number of estimated parameters.
    #[must_use]
    pub fn params(&self) -> usize {
        self.param_names.len()
    }

    /// `K`.
    #[must_use]
    pub fn basis_size(&self) -> usize {
        self.basis_names.len()
    }

    /// `E`.
    #[must_use]
    pub fn equations(&self) -> usize {
        self.equation_constraint.len()
    }

    /// Reads the constants of a symbolic model.
    #[must_use]
    pub fn from_model(m: &SymbolicModel) -> Self {
        let n = m.joint_count();
        let np = m.param_count();
        let mut offsets = vec![0];
        for j in 0..m.constraint_count() {
            let len = m.constraint_kind(j).value_count(m.dim());
            offsets.push(offsets[j] + len);
        }
        Summary {
            name: m.name().to_string(),
            dim: m.dim(),
            prismatic: (0..n).map(|i| m.joint_is_prismatic(i)).collect(),
            limits: (0..n).map(|i| m.joint_limits(i)).collect(),
            param_names: m.param_names().to_vec(),
            param_nominals: (0..np).map(|j| m.param_nominal(j)).collect(),
            param_is_angle: m
                .expansion()
                .param_vars
                .iter()
                .map(|v| matches!(v, ParamVars::Angle(..)))
                .collect(),
            identifiable: (0..np).map(|j| m.param_identifiable(j)).collect(),
            held: (0..np).map(|j| m.param_held(j)).collect(),
            identifiable_count: m.identifiable_count(),
            naive_size: m.naive_size(),
            basis_names: m.basis_names().to_vec(),
            constant_index: CalibModel::constant_index(m),
            constraint_kinds: (0..m.constraint_count())
                .map(|j| m.constraint_kind(j))
                .collect(),
            constraint_offsets: offsets,
            equation_constraint: (0..m.equation_count())
                .map(|e| m.equation_constraint(e))
                .collect(),
            gauge: m.gauge(),
            chain: crate::spec::chain::Chain::from_spec(m.spec()),
            relations: m.spec().relations.clone(),
        }
    }
}

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
        let vars = &model.expansion().vars;
        let red = model.reduction();

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

/// How a slot enters the numeric programs.
enum SlotValue {
    /// An exact constant (or a known parameter's nominal).
    Exact(Exact),
    /// Estimated parameter `j`.
    Param(usize),
}

fn slot_value(spec: &Spec, estimated: &[String], s: &Slot) -> SlotValue {
    match s {
        Slot::Const(e) => SlotValue::Exact(e.clone()),
        Slot::Param(name) => match estimated.iter().position(|n| n == name) {
            Some(j) => SlotValue::Param(j),
            None => SlotValue::Exact(
                spec.param(name)
                    .map_or_else(Exact::zero, |p| p.nominal.clone()),
            ),
        },
    }
}

/// Numeric program context: the builder and the slot resolution.
struct Numeric<'a> {
    b: Builder,
    spec: &'a Spec,
    estimated: Vec<String>,
}

/// A 3×4 affine transform `[R | t]` of affine combinations.
type Affine = [[LinComb; 4]; 3];

impl Numeric<'_> {
    fn new(spec: &Spec) -> Numeric<'_> {
        Numeric {
            b: Builder::default(),
            spec,
            estimated: spec
                .estimated_params()
                .iter()
                .map(|p| p.name.clone())
                .collect(),
        }
    }

    fn length(&mut self, s: &Slot) -> LinComb {
        match slot_value(self.spec, &self.estimated, s) {
            SlotValue::Exact(e) => LinComb::constant(e.to_f64()),
            SlotValue::Param(j) => LinComb::value(self.b.p(j)),
        }
    }

    /// `(cos, sin)` of an angle slot; exact for multiples of π/2.
    fn angle(&mut self, s: &Slot) -> (LinComb, LinComb) {
        match slot_value(self.spec, &self.estimated, s) {
            SlotValue::Exact(e) => exact_cos_sin(&e),
            SlotValue::Param(j) => {
                let x = self.b.p(j);
                (LinComb::value(self.b.cos(x)), LinComb::value(self.b.sin(x)))
            }
        }
    }

    /// `(cos θ, sin θ)` of `θ = q_i − home`.
    fn joint_angle(&mut self, i: usize, home: &Slot) -> (LinComb, LinComb) {
        let q = LinComb::value(self.b.q(i));
        match slot_value(self.spec, &self.estimated, home) {
            SlotValue::Exact(e) if e.exact_cos_sin().is_some() => {
                // cos(q − h) = cos q·cos h + sin q·sin h; sin(q − h) = sin q·cos h − cos q·sin h
                let (ch, sh) = exact_cos_sin(&e);
                let (cq, sq) = (self.b.cos_of(&q), self.b.sin_of(&q));
                let c = cq.scale(ch.constant).add_scaled(&sq, sh.constant);
                let s = sq.scale(ch.constant).add_scaled(&cq, -sh.constant);
                (c, s)
            }
            SlotValue::Exact(e) => {
                let theta = q.add_scaled(&LinComb::constant(e.to_f64()), -1.0);
                (self.b.cos_of(&theta), self.b.sin_of(&theta))
            }
            SlotValue::Param(j) => {
                let theta = q.add_scaled(&LinComb::value(self.b.p(j)), -1.0);
                (self.b.cos_of(&theta), self.b.sin_of(&theta))
            }
        }
    }

    fn compose(&mut self, a: &Affine, b: &Affine) -> Affine {
        let mut r: Affine = Default::default();
        for i in 0..3 {
            for j in 0..4 {
                let mut acc = if j == 3 {
                    a[i][3].clone()
                } else {
                    LinComb::default()
                };
                for k in 0..3 {
                    let t = self.b.times(&a[i][k], &b[k][j]);
                    acc = self.b.add(&acc, &t);
                }
                r[i][j] = acc;
            }
        }
        r
    }
}

fn exact_cos_sin(e: &Exact) -> (LinComb, LinComb) {
    match e.exact_cos_sin() {
        Some((c, s)) => (
            LinComb::constant(f64::from(c)),
            LinComb::constant(f64::from(s)),
        ),
        None => {
            let x = e.to_f64();
            (LinComb::constant(x.cos()), LinComb::constant(x.sin()))
        }
    }
}

fn c(x: f64) -> LinComb {
    LinComb::constant(x)
}

fn identity() -> Affine {
    let mut r: Affine = Default::default();
    for (i, row) in r.iter_mut().enumerate() {
        row[i] = c(1.0);
    }
    r
}

fn rot_z(cs: &(LinComb, LinComb)) -> Affine {
    let (co, si) = cs;
    [
        [co.clone(), si.scale(-1.0), c(0.0), c(0.0)],
        [si.clone(), co.clone(), c(0.0), c(0.0)],
        [c(0.0), c(0.0), c(1.0), c(0.0)],
    ]
}

fn rot_x(cs: &(LinComb, LinComb)) -> Affine {
    let (co, si) = cs;
    [
        [c(1.0), c(0.0), c(0.0), c(0.0)],
        [c(0.0), co.clone(), si.scale(-1.0), c(0.0)],
        [c(0.0), si.clone(), co.clone(), c(0.0)],
    ]
}

fn rot_y(cs: &(LinComb, LinComb)) -> Affine {
    let (co, si) = cs;
    [
        [co.clone(), c(0.0), si.clone(), c(0.0)],
        [c(0.0), c(1.0), c(0.0), c(0.0)],
        [si.scale(-1.0), c(0.0), co.clone(), c(0.0)],
    ]
}

fn translate(x: LinComb, y: LinComb, z: LinComb) -> Affine {
    let mut r = identity();
    r[0][3] = x;
    r[1][3] = y;
    r[2][3] = z;
    r
}

/// The forward kinematics `x(q; p)` as a numeric DH product (the conventions of
/// [`crate::spec::kinematics`]): `B·A_1⋯A_n·(tool, 1)`, the first `dim` rows.
fn tip_program(spec: &Spec) -> Program {
    let mut n = Numeric::new(spec);
    let mut t = match &spec.base {
        Some(base) => {
            let (x, y, z) = (n.length(&base.x), n.length(&base.y), n.length(&base.z));
            let (roll, pitch, yaw) = (
                n.angle(&base.roll),
                n.angle(&base.pitch),
                n.angle(&base.yaw),
            );
            let m = n.compose(&translate(x, y, z), &rot_z(&yaw));
            let m = n.compose(&m, &rot_y(&pitch));
            n.compose(&m, &rot_x(&roll))
        }
        None => identity(),
    };
    for (i, j) in spec.joints.iter().enumerate() {
        let (theta, d) = match j.kind {
            JointKind::Revolute => (n.joint_angle(i, &j.home), n.length(&j.d)),
            JointKind::Prismatic => {
                let q = LinComb::value(n.b.q(i));
                let d = q.add_scaled(&n.length(&j.offset), 1.0);
                let d = d.add_scaled(&n.length(&j.d), 1.0);
                (n.angle(&j.theta), d)
            }
        };
        let a = n.length(&j.a);
        let alpha = n.angle(&j.alpha);
        let tz = translate(c(0.0), c(0.0), d);
        let tx = translate(a, c(0.0), c(0.0));
        let factors = match spec.convention {
            Convention::Dh => [rot_z(&theta), tz, tx, rot_x(&alpha)],
            Convention::Mdh => [rot_x(&alpha), tx, rot_z(&theta), tz],
        };
        for f in &factors {
            t = n.compose(&t, f);
        }
    }
    let mut tool = [c(0.0), c(0.0), c(0.0)];
    for (k, s) in spec.tool.iter().enumerate().take(3) {
        tool[k] = n.length(s);
    }
    let mut outputs = Vec::new();
    for row in t.iter().take(spec.dim) {
        let mut acc = row[3].clone();
        for (k, tk) in tool.iter().enumerate() {
            let prod = n.b.times(&row[k], tk);
            acc = n.b.add(&acc, &prod);
        }
        outputs.push(acc);
    }
    n.b.finish(outputs)
}

/// Every constraint's values (canonical order), concatenated.
fn constraint_program(spec: &Spec) -> Program {
    let mut n = Numeric::new(spec);
    let mut outputs = Vec::new();
    for con in &spec.constraints {
        for s in con.slots() {
            let v = n.length(s);
            outputs.push(v);
        }
    }
    n.b.finish(outputs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::constraint_function;
    use crate::spec::from_yaml_str;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    const SPECS: &[&str] = &[
        // Planar 2-link on a line (the paper's AdeptOne).
        "name: adept\ndim: 2\njoints:\n  - {type: revolute, a: a1, home: th1}\n  \
         - {type: revolute, a: a2, home: th2}\nparams:\n  a1: {nominal: 0.375}\n  \
         a2: {nominal: 0.425}\n  th1: {nominal: 0}\n  th2: {nominal: 0}\n  \
         b1: {nominal: -1.8}\n  b2: {nominal: -0.5}\nconstraint:\n  line: {b: [b1, b2]}\n",
        // Spatial, modified DH, a prismatic joint, a base, a known irrational angle, a known
        // length, a sphere.
        "name: mixed\ndim: 3\nconvention: mdh\njoints:\n  \
         - {type: revolute, a: 0, alpha: 0, d: d1, home: th1}\n  \
         - {type: revolute, a: a2, alpha: pi/2, home: th2}\n  \
         - {type: prismatic, a: a3, alpha: tw, theta: 0, offset: o3}\n  \
         - {type: revolute, a: 0.1, alpha: 2*pi/3, d: 0.05, home: 0.3}\n\
         tool: [tx, 0, L]\nbase: {x: bx, y: 0.2, z: 0, roll: 0, pitch: 0.1, yaw: yw}\n\
         params:\n  d1: {nominal: 0.3}\n  th1: {nominal: 0.01}\n  a2: {nominal: 0.4}\n  \
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
                let got = prog.basis.eval(&q, &[]);
                for (a, b) in got.iter().zip(&want) {
                    assert!(close(*a, *b, 10.0), "{}: basis {a} vs {b}", spec.name);
                }
                let mut want = vec![0.0; e * k];
                m.generalized_params(&p, &mut want);
                let got = prog.generalized_params.eval(&[], &p);
                for (a, b) in got.iter().zip(&want) {
                    assert!(close(*a, *b, 10.0), "{}: c {a} vs {b}", spec.name);
                }
                let mut want = vec![0.0; e * k * np];
                m.jacobian(&p, &mut want);
                let got = prog.jacobian.eval(&[], &p);
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
                    let phi = prog.basis.eval(&q, &[]);
                    let cc = prog.generalized_params.eval(&[], &p);
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
        assert_eq!(prog.basis.op_counts().0, 4);
        // No value is computed twice.
        for (i, a) in prog.basis.ops.iter().enumerate() {
            assert!(!prog.basis.ops[..i].contains(a), "{a:?} twice");
        }
        let text = prog.basis.to_string();
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
}
