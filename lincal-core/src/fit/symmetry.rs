//! Exact discrete symmetries of a chain, and the canonical choice among equivalent solutions.
//!
//! A half-turn about z inserted after a z-rotation factor `f_a` commutes with every z-motion
//! and flips every x- and y-motion it passes (`Rz(π)·Rx(v) = Rx(−v)·Rz(π)`, likewise `Tx`,
//! `Ry`, `Ty`), until a later z-rotation `f_b` absorbs it, or the chain ends (a half-turn about
//! z leaves the frame's origin, the tip, where it is). So
//!
//! `θ_a → θ_a + π`, every x/y motion between `a` and `b` negated, `θ_b → θ_b + π`
//!
//! leaves the tip unchanged for every joint reading. In DH terms this is the familiar mirror
//! `home_i → home_i − π, a_i → −a_i, α_i → −α_i, home_{i+1} → home_{i+1} − π` (MDH:
//! `α_i, a_i` negated with the homes on both sides of them shifted). A fit from a far start
//! can land on any of these equivalents; they fit identically, so lincal reports the one
//! nearest the nominals, always: first the one with the fewest lengths whose sign differs from
//! a non-zero nominal, then the one with the smallest distance (angles wrapped, lengths in
//! units of the data's scale).
//!
//! A generator exists where the parameters can express it: `f_a` (and `f_b`) has a free
//! angle parameter term, and every x/y motion in between is a single free parameter with no
//! constant part (a constant twist like `π/2` cannot be negated). Each candidate is verified
//! numerically (tips and constraint values unchanged at fixed joint readings) before use, so
//! a parameter shared between slots cannot make a wrong one slip through.

use crate::model::chain::{Axis, Factor};
use crate::model::CalibModel;
use crate::numeric::wrap_angle;

/// One generator: parameters shifted by π and parameters negated.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Flip {
    /// Angle parameters shifted by π.
    pub shifted: Vec<usize>,
    /// Parameters negated.
    pub negated: Vec<usize>,
}

impl Flip {
    fn apply(&self, p: &mut [f64]) {
        for &j in &self.shifted {
            p[j] += std::f64::consts::PI;
        }
        for &j in &self.negated {
            p[j] = -p[j];
        }
    }
}

/// The single free parameter of a factor whose amount is exactly `±p_j` (no constant, no
/// joint), or of a z-rotation whose parameter shifts its amount.
fn free_term(f: &Factor, free: &[bool]) -> Option<usize> {
    let mut terms = f.terms.iter().flatten();
    let t = terms.next()?;
    if terms.next().is_some() || !free[t.param] || t.coef.abs() != 1.0 {
        return None;
    }
    Some(t.param)
}

/// The verified generators of the model's chain at `p`.
#[must_use]
pub fn generators(model: &dyn CalibModel, p: &[f64]) -> Vec<Flip> {
    let np = model.param_count();
    let free: Vec<bool> = (0..np).map(|j| !model.param_held(j)).collect();
    let chain = model.chain();
    let mut out = Vec::new();
    // Walk the chain: `open` is the last z-rotation that can start a flip, with the x/y
    // parameters negated since it.
    let mut open: Option<(usize, Vec<usize>)> = None;
    for f in chain {
        let z_rot = f.rotation && f.axis == Axis::Z;
        if z_rot {
            // A z-rotation without a free angle commutes with the half-turn: pass through.
            if let Some(b) = free_term(f, &free).filter(|&j| model.param_is_angle(j)) {
                if let Some((a, negated)) = &open {
                    out.push(Flip {
                        shifted: vec![*a, b],
                        negated: negated.clone(),
                    });
                }
                open = Some((b, Vec::new()));
            }
        } else if f.axis == Axis::Z {
            // z translations commute with the half-turn.
        } else if let Some((_, negated)) = &mut open {
            match free_term(f, &free) {
                Some(j) if f.constant == 0.0 && f.joint.is_none() => negated.push(j),
                // A constant amount (or a joint) cannot be negated: no flip spans this.
                _ if f.constant == 0.0
                    && f.joint.is_none()
                    && f.terms.iter().all(Option::is_none) => {}
                _ => open = None,
            }
        }
    }
    if let Some((a, negated)) = open {
        out.push(Flip {
            shifted: vec![a],
            negated,
        });
    }
    out.retain(|g| verified(model, p, g));
    out
}

/// Whether `g` leaves tips and constraint values unchanged at `p`.
fn verified(model: &dyn CalibModel, p: &[f64], g: &Flip) -> bool {
    let mut pf = p.to_vec();
    g.apply(&mut pf);
    let dim = model.dim();
    let nj = model.joint_count();
    let (mut a, mut b) = (vec![0.0; dim], vec![0.0; dim]);
    let scale = p.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    let close = |x: &[f64], y: &[f64]| x.iter().zip(y).all(|(u, v)| (u - v).abs() <= 1e-9 * scale);
    for s in 0..4 {
        let q: Vec<f64> = (0..nj)
            .map(|i| 0.37 + 0.91 * i as f64 - 1.3 * f64::from(s))
            .collect();
        model.tip(&q, p, &mut a);
        model.tip(&q, &pf, &mut b);
        if !close(&a, &b) {
            return false;
        }
    }
    (0..model.constraint_count()).all(|j| {
        let nv = model.constraint_kind(j).value_count(dim);
        let (mut u, mut v) = (vec![0.0; nv], vec![0.0; nv]);
        model.constraint_values(j, p, &mut u);
        model.constraint_values(j, &pf, &mut v);
        close(&u, &v)
    })
}

/// How far `p` is from the nominals: first the number of lengths whose sign differs from a
/// non-zero nominal (a length's sign is a physical fact: a link does not point backwards),
/// then the squared distance, wrapped angle differences in radians and lengths in units of
/// `scale`.
fn distance(model: &dyn CalibModel, p: &[f64], scale: f64) -> (usize, f64) {
    let mut wrong = 0;
    let mut d2 = 0.0;
    for (j, &v) in p.iter().enumerate() {
        let nom = model.param_nominal(j);
        let d = if model.param_is_angle(j) {
            wrap_angle(v - nom)
        } else {
            if nom != 0.0 && v != 0.0 && v.signum() != nom.signum() {
                wrong += 1;
            }
            (v - nom) / scale
        };
        d2 += d * d;
    }
    (wrong, d2)
}

fn nearer(a: (usize, f64), b: (usize, f64)) -> bool {
    a.0 < b.0 || (a.0 == b.0 && a.1 < b.1 - 1e-12)
}

/// Replaces `p` by its equivalent nearest the nominals (see the module docs); `scale` is the
/// length that weighs length differences against angles (the data's scale). Returns the
/// number of generators applied.
pub fn canonicalize(model: &dyn CalibModel, p: &mut [f64], scale: f64) -> usize {
    let gens = generators(model, p);
    if gens.is_empty() {
        return 0;
    }
    let scale = if scale > 0.0 { scale } else { 1.0 };
    let best_of = |mask: u32| {
        let mut q = p.to_vec();
        for (i, g) in gens.iter().enumerate() {
            if mask & (1 << i) != 0 {
                g.apply(&mut q);
            }
        }
        q
    };
    let mut chosen = 0u32;
    let mut best = distance(model, p, scale);
    if gens.len() <= 12 {
        for mask in 1..(1u32 << gens.len()) {
            let d = distance(model, &best_of(mask), scale);
            if nearer(d, best) {
                best = d;
                chosen = mask;
            }
        }
    } else {
        // Greedy, twice round: each generator taken when it brings the point nearer.
        for _ in 0..2 {
            for i in 0..gens.len() {
                let d = distance(model, &best_of(chosen ^ (1 << i)), scale);
                if nearer(d, best) {
                    best = d;
                    chosen ^= 1 << i;
                }
            }
        }
    }
    let q = best_of(chosen);
    p.copy_from_slice(&q);
    chosen.count_ones() as usize
}
