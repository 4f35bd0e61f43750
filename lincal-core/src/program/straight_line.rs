//! Straight-line programs: [`ValueId`], [`Op`] (one single-assignment value), [`LinComb`]
//! (an affine combination of values) and [`Program`] (values, then outputs), with the
//! interpreter ([`Program::eval`]) and the printed form (one line per value and output).

use std::fmt;

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
