//! Each constraint kind's equations over the expanded tip: `x − p` for a point, `b·x + 1`
//! for lines and planes, `n·x − d` for a plane by normal, `‖x − c‖² − r²` for circles and
//! spheres (from the `‖tip‖²` carried along the chain), `b·x + 1 + Σ A_ij X_ij` for a quadric
//! (from the carried second moments `X = x xᵀ`), the tip itself when measured; and the size
//! of the largest product each forms, bounded before it is formed ([`super::expand`]).

use super::chain_poly::ChainPoly;
use super::link::{m, moment};
use crate::error::Result;
use crate::spec::Constraint;
use std::borrow::Cow;

/// The largest product the constraint function forms, bounded before it is formed.
pub(super) fn predicted_constraint<P: ChainPoly>(
    c: &Constraint,
    tip: &[P],
    dim: usize,
    has_norm2: bool,
    moments: Option<&[P; 6]>,
) -> usize {
    let t = |i: usize| tip.get(i).map_or(0, P::len);
    let tip_max = (0..dim).map(t).max().unwrap_or(0);
    match c {
        // b·x + 1 + Σ A_ij X_ij with one-term A_ij.
        Constraint::Quadric { .. } if moments.is_some() => {
            let x2 = moments.map_or(0, |x2| x2.iter().map(P::len).sum::<usize>());
            x2 + (0..dim).map(t).sum::<usize>() + 1
        }
        Constraint::Quadric { .. } => tip_max.saturating_mul(tip_max).saturating_mul(dim * dim),
        Constraint::Circle { .. } | Constraint::Sphere { .. } if !has_norm2 => {
            tip_max.saturating_mul(tip_max).saturating_mul(dim)
        }
        // b·x + 1 with one-term b_i, or the tip itself.
        _ => (0..dim).map(t).sum::<usize>() + 1,
    }
}

/// The kind's formula over the slot values `vals` (in [`Constraint::slots`] order) and the
/// tip: `x − p` for a point, `b·x + 1` for lines and planes, `n·x − d` for a plane by normal,
/// `‖x − c‖² − r²` for circles and
/// spheres, `xᵀAx + b·x + 1` for a quadric, the tip itself when measured.
pub(super) fn constraint_polys<P: ChainPoly>(
    c: &Constraint,
    vals: &[P],
    tip: Cow<'_, [P]>,
    (norm2, moments): (Option<&P>, Option<&[P; 6]>),
    dim: usize,
    pairs: &P::Ctx,
) -> Result<Vec<P>> {
    // `start + b·x`, each product added in place into one table sized for all of them.
    let dot = |start: P, bv: &[P]| -> Result<P> {
        let mut h = start;
        let products = bv.iter().zip(tip.iter()).map(|(b, x)| b.len() * x.len());
        h.reserve(products.sum());
        for (bi, xi) in bv.iter().zip(tip.iter()) {
            h.add_product(bi, xi, pairs)?;
        }
        Ok(h)
    };
    let dot_plus_one = |bv: &[P]| dot(P::int(1), bv);
    Ok(match c {
        Constraint::Point { .. } => {
            let mut x = tip.into_owned();
            x.truncate(vals.len());
            for (xi, p) in x.iter_mut().zip(vals) {
                xi.add_assign(&p.neg());
            }
            x
        }
        Constraint::Line2 { .. } | Constraint::Plane { .. } => vec![dot_plus_one(vals)?],
        // n·x − d: no "+1", so a plane through the origin (d = 0) is written too.
        Constraint::PlaneNormal { .. } => vec![dot(vals[3].neg(), &vals[..3])?],
        Constraint::Line3 { .. } => {
            vec![dot_plus_one(&vals[0..3])?, dot_plus_one(&vals[3..6])?]
        }
        Constraint::Circle { .. } | Constraint::Sphere { .. } => {
            // ‖x − c‖² − r² = ‖x‖² − 2 c·x + ‖c‖² − r².
            let mut h = m(&vals[dim], &vals[dim], pairs)?.neg();
            match norm2 {
                Some(n) => {
                    // The large terms (‖x‖², then −2 c·x in place) first, the small after.
                    let scaled: Vec<P> = vals[..dim].iter().map(|cc| cc.scale_int(-2)).collect();
                    let mut big = dot(n.clone(), &scaled)?;
                    big.add_assign(&h);
                    for cc in &vals[..dim] {
                        big.add_assign(&cc.square(pairs)?);
                    }
                    h = big;
                }
                None => {
                    for (x, cc) in tip.iter().zip(vals) {
                        h = h.add(&x.sub(cc).square(pairs)?);
                    }
                }
            }
            vec![h]
        }
        Constraint::Quadric { .. } => {
            let mut h = dot_plus_one(&vals[dim * dim..])?;
            for i in 0..dim {
                for j in 0..dim {
                    let a = &vals[i * dim + j];
                    if a.is_zero() {
                        continue;
                    }
                    match moments {
                        Some(x2) => h.add_product(a, &x2[moment(i, j)], pairs)?,
                        None => h = h.add(&m(&m(a, &tip[i], pairs)?, &tip[j], pairs)?),
                    }
                }
            }
            vec![h]
        }
        // A measured pose: the coordinates here, its rotation entries appended by the caller.
        Constraint::Measured | Constraint::MeasuredPose { .. } => tip.into_owned(),
    })
}
