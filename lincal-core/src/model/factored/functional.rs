//! How an equation reads the chain: its functional `w_e` or `Q_e` from the constraint values
//! (and its derivative by one value), its degree and its probe.

use super::step::{Ring, State};
use crate::model::geometry::ConstraintKind;

/// How one equation reads the chain: the functional's degree, the constraint and the row
/// within it, and the probe vector `v_e`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Equation {
    pub(super) degree: u8,
    pub(super) kind: ConstraintKind,
    pub(super) row: usize,
    /// Start of the constraint's values.
    pub(super) offset: usize,
    pub(super) constraint: usize,
    pub(super) probe: [f64; 4],
}

/// The functional of an equation at the constraint values `vals`: `w_e` (degree one, the
/// first four entries) or `Q_e` (degree two). With `wrt = Some(v)`, its derivative with
/// respect to value `v` instead. Matches [`crate::model::geometry::constraint_function`].
pub(super) fn functional<S: Ring>(
    eq: &Equation,
    dim: usize,
    vals: &[S],
    wrt: Option<usize>,
) -> State<S> {
    let mut w = [S::ZERO; 16];
    let d = |i: usize| if wrt == Some(i) { S::ONE } else { S::ZERO };
    let val = |i: usize| if wrt.is_some() { d(i) } else { vals[i] };
    // The constant 1 of `b·x + 1`, which no value moves.
    let one = if wrt.is_some() { S::ZERO } else { S::ONE };
    match eq.kind {
        ConstraintKind::Point => {
            if wrt.is_none() {
                w[eq.row] = S::ONE;
            }
            w[3] = -val(eq.row);
        }
        ConstraintKind::Line2 | ConstraintKind::Plane => {
            for (i, w) in w.iter_mut().enumerate().take(eq.kind.value_count(dim)) {
                *w = val(i);
            }
            w[3] = one;
        }
        ConstraintKind::PlaneNormal => {
            for (i, w) in w.iter_mut().enumerate().take(3) {
                *w = val(i);
            }
            w[3] = -val(3);
        }
        ConstraintKind::Line3 => {
            for (i, w) in w.iter_mut().enumerate().take(3) {
                *w = val(3 * eq.row + i);
            }
            w[3] = one;
        }
        ConstraintKind::Measured | ConstraintKind::MeasuredPose => {
            if wrt.is_none() {
                w[if eq.row < 3 { eq.row } else { (eq.row - 3) % 3 }] = S::ONE;
            }
        }
        ConstraintKind::Circle | ConstraintKind::Sphere => {
            // ‖x − c‖² − r² = xᵀx − 2cᵀx + cᵀc − r²
            let mut corner = S::ZERO;
            for i in 0..dim {
                if wrt.is_none() {
                    w[5 * i] = S::ONE;
                    corner = corner + vals[i] * vals[i];
                } else {
                    corner = corner + (vals[i] + vals[i]) * d(i);
                }
                w[4 * i + 3] = -val(i);
                w[12 + i] = -val(i);
            }
            corner = corner
                - if wrt.is_some() {
                    (vals[dim] + vals[dim]) * d(dim)
                } else {
                    vals[dim] * vals[dim]
                };
            w[15] = corner;
        }
        ConstraintKind::Quadric => {
            // xᵀAx + bᵀx + 1, A symmetrised.
            for i in 0..dim {
                for j in 0..dim {
                    let a = (val(i * dim + j) + val(j * dim + i)).half();
                    w[4 * i + j] = a;
                }
                let b = val(dim * dim + i).half();
                w[4 * i + 3] = b;
                w[12 + i] = b;
            }
            w[15] = one;
        }
    }
    w
}
