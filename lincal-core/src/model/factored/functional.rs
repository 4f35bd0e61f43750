//! How an equation reads the chain: its functional `w_e` or `Q_e` from the constraint values
//! (and its derivative by one value), its degree and its probe.

use super::step::State;
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
pub(super) fn functional(eq: &Equation, dim: usize, vals: &[f64], wrt: Option<usize>) -> State {
    let mut w = [0.0; 16];
    let d = |i: usize| f64::from(u8::from(wrt == Some(i)));
    let val = |i: usize| if wrt.is_some() { d(i) } else { vals[i] };
    match eq.kind {
        ConstraintKind::Point => {
            if wrt.is_none() {
                w[eq.row] = 1.0;
            }
            w[3] = -val(eq.row);
        }
        ConstraintKind::Line2 | ConstraintKind::Plane => {
            for (i, w) in w.iter_mut().enumerate().take(eq.kind.value_count(dim)) {
                *w = val(i);
            }
            w[3] = if wrt.is_some() { 0.0 } else { 1.0 };
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
            w[3] = if wrt.is_some() { 0.0 } else { 1.0 };
        }
        ConstraintKind::Measured | ConstraintKind::MeasuredPose => {
            if wrt.is_none() {
                w[if eq.row < 3 { eq.row } else { (eq.row - 3) % 3 }] = 1.0;
            }
        }
        ConstraintKind::Circle | ConstraintKind::Sphere => {
            // ‖x − c‖² − r² = xᵀx − 2cᵀx + cᵀc − r²
            let mut corner = 0.0;
            for i in 0..dim {
                if wrt.is_none() {
                    w[5 * i] = 1.0;
                    corner += vals[i] * vals[i];
                } else {
                    corner += 2.0 * vals[i] * d(i);
                }
                w[4 * i + 3] = -val(i);
                w[12 + i] = -val(i);
            }
            corner -= if wrt.is_some() {
                2.0 * vals[dim] * d(dim)
            } else {
                vals[dim] * vals[dim]
            };
            w[15] = corner;
        }
        ConstraintKind::Quadric => {
            // xᵀAx + bᵀx + 1, A symmetrised.
            for i in 0..dim {
                for j in 0..dim {
                    let a = 0.5 * (val(i * dim + j) + val(j * dim + i));
                    w[4 * i + j] = a;
                }
                let b = 0.5 * val(dim * dim + i);
                w[4 * i + 3] = b;
                w[12 + i] = b;
            }
            w[15] = if wrt.is_some() { 0.0 } else { 1.0 };
        }
    }
    w
}
