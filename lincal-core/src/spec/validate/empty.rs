//! Known constraints that hold for no point: a plane or line `b·x + 1 = 0` with `b = 0`, a
//! 3-D line whose two planes are parallel, a quadric `xᵀAx + bᵀx + 1 = 0` with no real
//! point. Each is refused at its field, where the data would otherwise be blamed (a residual
//! that is not finite at pose 0) or fitted to a shape that is not there (a residual of a
//! metre, exit 0). A constraint with an unknown entry is never refused: the fit moves it.

use nalgebra::{DMatrix, DVector, SymmetricEigen};

use super::Checker;
use crate::spec::{Param, Slot};

/// A slot's value when it is known: a number, or a known parameter's nominal.
fn known(s: &Slot, params: &[Param]) -> Option<f64> {
    match s {
        Slot::Const(e) => Some(e.to_f64()),
        Slot::Param(n) => params
            .iter()
            .find(|p| &p.name == n && p.known)
            .map(|p| p.nominal.to_f64()),
    }
}

/// Every slot's value when all are known.
fn all_known(slots: &[Slot], params: &[Param]) -> Option<Vec<f64>> {
    slots.iter().map(|s| known(s, params)).collect()
}

/// A known `b` of `b·x + 1 = 0` (plane or line) is not all zero: `0·x + 1 = 0` holds for no
/// `x`, so it describes no plane or line (every entry a number or a known parameter whose
/// nominal is 0).
pub(super) fn check_b_not_zero(ck: &mut Checker<'_>, field: &str, b: &[Slot], params: &[Param]) {
    if all_known(b, params).is_some_and(|v| !v.is_empty() && v.iter().all(|&x| x == 0.0)) {
        ck.at_value(
            field,
            "b is known and zero: `0·x + 1 = 0` holds for no point, so it describes no \
             plane or line (b is the normal divided by minus the offset, so a plane through \
             the origin has no b)"
                .into(),
        );
    }
}

/// A 3-D line `b₁·x + 1 = 0`, `b₂·x + 1 = 0`: neither plane's `b` is known and zero, and two
/// known planes are not parallel (`b₁ × b₂ = 0`: the same plane, which is no line, or two
/// parallel ones, which meet nowhere).
pub(super) fn check_line_planes(
    ck: &mut Checker<'_>,
    base: &str,
    planes: &[[Slot; 3]; 2],
    params: &[Param],
) {
    let field = format!("{base}.planes");
    for (i, b) in planes.iter().enumerate() {
        check_b_not_zero(ck, &format!("{field}[{i}]"), b, params);
    }
    let (Some(b1), Some(b2)) = (all_known(&planes[0], params), all_known(&planes[1], params))
    else {
        return;
    };
    let (u, v) = (DVector::from_vec(b1), DVector::from_vec(b2));
    let (nu, nv) = (u.norm(), v.norm());
    if nu == 0.0 || nv == 0.0 {
        return;
    }
    let sine = (u.norm_squared() * v.norm_squared() - u.dot(&v).powi(2))
        .max(0.0)
        .sqrt()
        / (nu * nv);
    if sine < 1e-9 {
        let what = if (&u - &v).norm() <= 1e-12 * nu.max(nv) {
            "the two planes are the same plane, which is no line"
        } else {
            "the two planes are parallel and meet nowhere"
        };
        ck.at_value(
            &field,
            format!("{what} (b₁ × b₂ = 0): a line is where two planes that are not parallel meet"),
        );
    }
}

/// A known quadric `xᵀAx + bᵀx + 1 = 0` has a real point. In the eigenbasis of `A`
/// (`λ_i`, `β_i = v_iᵀb`), `f(y) = Σ λ_i y_i² + β_i y_i + 1` is `1` at `y = 0`, so a point
/// exists unless `f` is bounded below by a positive number: no `λ_i < 0`, no linear term
/// along a null direction (`λ_i = 0`, `β_i ≠ 0`), and the minimum
/// `1 − Σ_{λ_i > 0} β_i²/(4λ_i)` positive (`A = I`, `b = 0`: `‖x‖² + 1 = 0`; `A = 0`,
/// `b = 0`: `1 = 0`). A shape `check_quadric` refuses is not judged here.
pub(super) fn check_quadric_has_points(
    ck: &mut Checker<'_>,
    base: &str,
    a: &[Vec<Slot>],
    b: &[Slot],
    params: &[Param],
) {
    let n = a.len();
    if n == 0 || b.len() != n || a.iter().any(|row| row.len() != n) {
        return;
    }
    let rows: Option<Vec<Vec<f64>>> = a.iter().map(|row| all_known(row, params)).collect();
    let (Some(rows), Some(b)) = (rows, all_known(b, params)) else {
        return;
    };
    let a = DMatrix::from_fn(n, n, |r, c| 0.5 * (rows[r][c] + rows[c][r]));
    if !a.iter().chain(&b).all(|x| x.is_finite()) {
        return;
    }
    let eig = SymmetricEigen::new(a);
    let scale = eig.eigenvalues.amax();
    let b = DVector::from_vec(b);
    let mut minimum = 1.0;
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        let beta = eig.eigenvectors.column(k).dot(&b);
        if l < -1e-12 * scale {
            return;
        }
        if l <= 1e-12 * scale {
            if beta.abs() > 1e-12 * b.amax().max(1.0) {
                return;
            }
        } else {
            minimum -= beta * beta / (4.0 * l);
        }
    }
    if minimum > 1e-9 {
        ck.at_value(
            base,
            format!(
                "the quadric is known and holds for no real point: xᵀAx + bᵀx + 1 is at least \
                 {minimum:.6} everywhere (A has no negative eigenvalue and b leaves it bounded \
                 below), so no tip can lie on it; check the signs of A and b"
            ),
        );
    }
}
