//! The [`Builder`] of a [`Program`]: values hash-consed as they are asked for (every input,
//! `cos`/`sin`, product and monomial computed once), affine combinations with constants
//! folded, and the finished program with the values its outputs do not reach dropped.

use std::collections::HashMap;

use super::straight_line::{LinComb, Op, Program, ValueId};
use crate::symbolic::monomial::Mono;

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
pub(super) struct Builder {
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

    pub(super) fn q(&mut self, i: usize) -> ValueId {
        self.push(Key::Q(i), Op::Q(i))
    }

    pub(super) fn p(&mut self, j: usize) -> ValueId {
        self.push(Key::P(j), Op::P(j))
    }

    pub(super) fn cos(&mut self, v: ValueId) -> ValueId {
        self.push(Key::Cos(v), Op::Cos(v))
    }

    pub(super) fn sin(&mut self, v: ValueId) -> ValueId {
        self.push(Key::Sin(v), Op::Sin(v))
    }

    pub(super) fn mul(&mut self, a: ValueId, b: ValueId) -> ValueId {
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        self.push(Key::Mul(a, b), Op::Mul(a, b))
    }

    /// A value holding `l` (the value itself when `l` is one plain term).
    pub(super) fn materialize(&mut self, l: &LinComb) -> ValueId {
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

    pub(super) fn add(&mut self, a: &LinComb, b: &LinComb) -> LinComb {
        a.add_scaled(b, 1.0)
    }

    pub(super) fn times(&mut self, a: &LinComb, b: &LinComb) -> LinComb {
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

    pub(super) fn cos_of(&mut self, a: &LinComb) -> LinComb {
        if a.is_constant() {
            return LinComb::constant(a.constant.cos());
        }
        let x = self.materialize(a);
        LinComb::value(self.cos(x))
    }

    pub(super) fn sin_of(&mut self, a: &LinComb) -> LinComb {
        if a.is_constant() {
            return LinComb::constant(a.constant.sin());
        }
        let x = self.materialize(a);
        LinComb::value(self.sin(x))
    }

    /// The value of monomial `m` (`None` for the constant monomial), each factor's value from
    /// `var`; built from `m` with one factor of its highest variable removed.
    pub(super) fn mono(
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
    pub(super) fn finish(self, outputs: Vec<LinComb>) -> Program {
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
