//! Constraint geometry, numeric and `no_std`: the constraint function `h(x)` the symbolic engine
//! expands, and the geometric residual (distance of a tip from the constraint) that refinement
//! minimises. Both model sources (derived and run-time) call these, so they agree by
//! construction.
//!
//! Constraint values come in the canonical order of [`ConstraintKind::value_count`]:
//! point `p`; 2-D line `b`; 3-D line `b₁, b₂`; plane `b`; plane by normal `n` then offset
//! `d`; circle and sphere `center, r`;
//! quadric `A` (row-major) then `b`; measured: none.

/// The kind of a constraint, independent of its parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ConstraintKind {
    /// Pinned tip `x = p`.
    Point,
    /// 2-D line `b·x + 1 = 0`.
    Line2,
    /// 3-D line, two planes `b₁·x + 1 = 0`, `b₂·x + 1 = 0`.
    Line3,
    /// Plane `b·x + 1 = 0`.
    Plane,
    /// Plane by normal and offset, `n·x − d = 0` (values `n₁, n₂, n₃, d`; any `n ≠ 0`).
    PlaneNormal,
    /// Circle `‖x − c‖ = r`.
    Circle,
    /// Sphere `‖x − c‖ = r`.
    Sphere,
    /// Quadric `xᵀAx + bᵀx + 1 = 0`.
    Quadric,
    /// Measured tip: `x` is given by the data.
    Measured,
    /// Measured tool frame: position and orientation given by the data (dim 3). Its
    /// equations are the 3 tip coordinates and the 9 entries of the tool rotation
    /// (column-major, see [`crate::model::rotation`]); its residual the position error and
    /// the rotation vector `log(R_mᵀR)`.
    MeasuredPose,
}

impl ConstraintKind {
    /// Number of constraint values (see the module docs for their order).
    #[must_use]
    pub const fn value_count(self, dim: usize) -> usize {
        match self {
            ConstraintKind::Point => dim,
            ConstraintKind::Line2 => 2,
            ConstraintKind::Line3 => 6,
            ConstraintKind::Plane => 3,
            ConstraintKind::PlaneNormal => 4,
            ConstraintKind::Circle | ConstraintKind::Sphere => dim + 1,
            ConstraintKind::Quadric => dim * dim + dim,
            ConstraintKind::Measured | ConstraintKind::MeasuredPose => 0,
        }
    }

    /// Number of scalar equations `h_e(x) = 0` a tip on this constraint satisfies
    /// (for `Measured`, the `dim` coordinates regressed on the basis; for `MeasuredPose`, the
    /// 3 coordinates and the 9 rotation entries).
    #[must_use]
    pub const fn equation_count(self, dim: usize) -> usize {
        match self {
            ConstraintKind::MeasuredPose => 12,
            ConstraintKind::Point | ConstraintKind::Measured => dim,
            ConstraintKind::Line3 => 2,
            _ => 1,
        }
    }

    /// Number of geometric residual components per pose (a measured pose: 3 position, then
    /// 3 orientation).
    #[must_use]
    pub const fn residual_count(self, dim: usize) -> usize {
        match self {
            ConstraintKind::MeasuredPose => 6,
            ConstraintKind::Point | ConstraintKind::Measured => dim,
            ConstraintKind::Line3 => 2,
            _ => 1,
        }
    }

    /// The interface's name of the kind.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            ConstraintKind::Point => "point",
            ConstraintKind::Line2 | ConstraintKind::Line3 => "line",
            ConstraintKind::Plane | ConstraintKind::PlaneNormal => "plane",
            ConstraintKind::Circle => "circle",
            ConstraintKind::Sphere => "sphere",
            ConstraintKind::Quadric => "quadric",
            ConstraintKind::Measured => "measured",
            ConstraintKind::MeasuredPose => "measured_pose",
        }
    }

    /// Whether the data gives the values of this kind's equations (`measured`,
    /// `measured_pose`): its linear method is a regression, not a null space.
    #[must_use]
    pub const fn is_measured(self) -> bool {
        matches!(
            self,
            ConstraintKind::Measured | ConstraintKind::MeasuredPose
        )
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The constraint function(s) `h(x)`, exactly the polynomials the symbolic engine expands:
/// point `x − p`; line and plane `b·x + 1`; plane by normal `n·x − d`; 3-D line both planes;
/// circle and sphere
/// `‖x − c‖² − r²`; quadric `xᵀAx + bᵀx + 1`. For `Measured`, `out = x` (the regressed
/// coordinates). Writes [`ConstraintKind::equation_count`] values.
pub fn constraint_function(
    kind: ConstraintKind,
    dim: usize,
    values: &[f64],
    x: &[f64],
    out: &mut [f64],
) {
    match kind {
        ConstraintKind::Point => {
            for i in 0..dim {
                out[i] = x[i] - values[i];
            }
        }
        ConstraintKind::Line2 | ConstraintKind::Plane => out[0] = dot(values, x) + 1.0,
        ConstraintKind::PlaneNormal => out[0] = dot(&values[..3], x) - values[3],
        ConstraintKind::Line3 => {
            out[0] = dot(&values[0..3], x) + 1.0;
            out[1] = dot(&values[3..6], x) + 1.0;
        }
        ConstraintKind::Circle | ConstraintKind::Sphere => {
            let mut s = 0.0;
            for i in 0..dim {
                let d = x[i] - values[i];
                s += d * d;
            }
            out[0] = s - values[dim] * values[dim];
        }
        ConstraintKind::Quadric => {
            let mut s = 1.0;
            for i in 0..dim {
                for j in 0..dim {
                    s += x[i] * values[i * dim + j] * x[j];
                }
                s += values[dim * dim + i] * x[i];
            }
            out[0] = s;
        }
        // A measured pose's rotation entries are not a function of the tip: the caller
        // appends them (see [`ConstraintKind::MeasuredPose`]).
        ConstraintKind::Measured | ConstraintKind::MeasuredPose => {
            out[..dim].copy_from_slice(&x[..dim]);
        }
    }
}

/// Scalars the geometric residual is written over: `f64`, and [`Dual`] for its exact
/// derivatives (one formula, so the residual and its Jacobian agree by construction).
pub trait Real:
    Copy
    + core::ops::Add<Output = Self>
    + core::ops::Sub<Output = Self>
    + core::ops::Mul<Output = Self>
    + core::ops::Div<Output = Self>
{
    /// A constant.
    fn constant(v: f64) -> Self;
    /// The square root.
    #[must_use]
    fn sqrt(self) -> Self;
    /// The value (without derivatives): for branches such as an absolute value.
    fn value(self) -> f64;
}

impl Real for f64 {
    #[inline]
    fn constant(v: f64) -> Self {
        v
    }
    #[inline]
    fn sqrt(self) -> Self {
        libm::sqrt(self)
    }
    #[inline]
    fn value(self) -> f64 {
        self
    }
}

/// Most inputs a residual has: a tip (3) and a 3-D quadric's values (12).
pub const MAX_INPUTS: usize = 15;

/// A forward-mode dual number: a value and its derivatives with respect to up to
/// [`MAX_INPUTS`] inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual {
    /// The value.
    pub v: f64,
    /// The derivatives.
    pub d: [f64; MAX_INPUTS],
}

impl Dual {
    /// Input number `i` with value `v` (derivative 1 with respect to itself).
    #[must_use]
    pub fn input(v: f64, i: usize) -> Self {
        let mut d = [0.0; MAX_INPUTS];
        d[i] = 1.0;
        Dual { v, d }
    }

    #[inline]
    fn map(self, v: f64, f: f64) -> Self {
        let mut d = self.d;
        for x in &mut d {
            *x *= f;
        }
        Dual { v, d }
    }
}

impl core::ops::Add for Dual {
    type Output = Dual;
    #[inline]
    fn add(self, o: Dual) -> Dual {
        let mut d = self.d;
        for (x, y) in d.iter_mut().zip(&o.d) {
            *x += y;
        }
        Dual { v: self.v + o.v, d }
    }
}

impl core::ops::Sub for Dual {
    type Output = Dual;
    #[inline]
    fn sub(self, o: Dual) -> Dual {
        let mut d = self.d;
        for (x, y) in d.iter_mut().zip(&o.d) {
            *x -= y;
        }
        Dual { v: self.v - o.v, d }
    }
}

impl core::ops::Mul for Dual {
    type Output = Dual;
    #[inline]
    fn mul(self, o: Dual) -> Dual {
        let mut d = [0.0; MAX_INPUTS];
        for ((x, a), b) in d.iter_mut().zip(&self.d).zip(&o.d) {
            *x = a * o.v + self.v * b;
        }
        Dual { v: self.v * o.v, d }
    }
}

impl core::ops::Div for Dual {
    type Output = Dual;
    #[inline]
    fn div(self, o: Dual) -> Dual {
        let v = self.v / o.v;
        let mut d = [0.0; MAX_INPUTS];
        for ((x, a), b) in d.iter_mut().zip(&self.d).zip(&o.d) {
            *x = (a - v * b) / o.v;
        }
        Dual { v, d }
    }
}

impl Real for Dual {
    #[inline]
    fn constant(v: f64) -> Self {
        Dual {
            v,
            d: [0.0; MAX_INPUTS],
        }
    }
    #[inline]
    fn sqrt(self) -> Self {
        let s = libm::sqrt(self.v);
        self.map(s, 0.5 / s)
    }
    #[inline]
    fn value(self) -> f64 {
        self.v
    }
}

/// A plane's signed offset `σ` along its unit normal, from its values `v` (the normal's `m`
/// entries first) and the normal's length `norm`: `e/‖a‖` for a plane by normal `a·x = e`
/// (its offset `e` follows the normal), `−1/‖b‖` for `b·x + 1 = 0` (nothing follows).
pub fn plane_offset<T: Real>(v: &[T], m: usize, norm: T) -> T {
    match v.get(m) {
        Some(&e) => e / norm,
        None => T::constant(-1.0) / norm,
    }
}

fn dot_r<T: Real>(a: &[T], b: &[T]) -> T {
    a.iter()
        .zip(b)
        .fold(T::constant(0.0), |acc, (&x, &y)| acc + x * y)
}

/// Geometric residual of a tip `x` from the constraint, in metres:
/// point `x − p`; line and plane the signed distance `(b·x + 1)/‖b‖`; plane by normal the
/// signed distance `(n·x − d)/‖n‖` (so `n` need not be of unit length); 3-D line the two
/// components of the offset from the line in an orthonormal frame of its normal plane;
/// circle and sphere `‖x − c‖ − r`; quadric the first-order (Sampson) distance
/// `h(x)/‖∇h(x)‖`. For `Measured`, `measured` holds the measured tip and the residual is
/// `x − measured`. Writes [`ConstraintKind::residual_count`] values.
pub fn geometric_residual(
    kind: ConstraintKind,
    dim: usize,
    values: &[f64],
    x: &[f64],
    measured: &[f64],
    out: &mut [f64],
) {
    residual_in(kind, dim, values, x, measured, out);
}

/// [`geometric_residual`] over any [`Real`].
pub fn residual_in<T: Real>(
    kind: ConstraintKind,
    dim: usize,
    values: &[T],
    x: &[T],
    measured: &[f64],
    out: &mut [T],
) {
    let one = T::constant(1.0);
    match kind {
        ConstraintKind::Point => {
            for i in 0..dim {
                out[i] = x[i] - values[i];
            }
        }
        ConstraintKind::Line2 | ConstraintKind::Plane => {
            let n = dot_r(values, values).sqrt();
            out[0] = (dot_r(values, x) + one) / n;
        }
        ConstraintKind::PlaneNormal => {
            let n = dot_r(&values[..3], &values[..3]).sqrt();
            out[0] = (dot_r(&values[..3], x) - values[3]) / n;
        }
        ConstraintKind::Line3 => {
            let (b1, b2) = (&values[0..3], &values[3..6]);
            let n1 = dot_r(b1, b1).sqrt();
            let r1 = (dot_r(b1, x) + one) / n1;
            // u2 = b2 with its component along u1 = b1/|b1| removed.
            let along = dot_r(b2, b1) / n1;
            let mut perp = [T::constant(0.0); 3];
            for i in 0..3 {
                perp[i] = b2[i] - along * b1[i] / n1;
            }
            let n2 = dot_r(&perp, &perp).sqrt();
            out[0] = r1;
            out[1] = ((dot_r(b2, x) + one) - along * r1) / n2;
        }
        ConstraintKind::Circle | ConstraintKind::Sphere => {
            let mut s = T::constant(0.0);
            for i in 0..dim {
                let d = x[i] - values[i];
                s = s + d * d;
            }
            out[0] = s.sqrt() - values[dim];
        }
        ConstraintKind::Quadric => {
            let mut h = one;
            let mut g2 = T::constant(0.0);
            for i in 0..dim {
                // ∇h = (A + Aᵀ)x + b
                let mut g = values[dim * dim + i];
                for j in 0..dim {
                    h = h + x[i] * values[i * dim + j] * x[j];
                    g = g + (values[i * dim + j] + values[j * dim + i]) * x[j];
                }
                h = h + values[dim * dim + i] * x[i];
                g2 = g2 + g * g;
            }
            out[0] = h / g2.sqrt();
        }
        // A measured pose: the position part here; its orientation part needs the rotation
        // ([`pose_residual`]).
        ConstraintKind::Measured | ConstraintKind::MeasuredPose => {
            for i in 0..dim {
                out[i] = x[i] - T::constant(measured[i]);
            }
        }
    }
}

/// The start of the orientation weight (metres per radian) when the noise levels are not
/// stated: an angle error counts as the position error it causes one metre from the tool
/// frame, about an arm's reach.
pub const DEFAULT_ORIENTATION_WEIGHT: f64 = 1.0;

/// The whole residual of a measured pose: the position error `x − x_m` (metres), then the
/// orientation error `w·log(R_mᵀR)` (the rotation vector in radians times `w`, the weight
/// that puts it in metres, `σ_position/σ_orientation`). `measured` is the pose's row after
/// the joints: `x, y, z`, then `R_m` column-major; `rot` the predicted rotation.
pub fn pose_residual(
    measured: &[f64],
    tip: &[f64; 3],
    rot: &[f64; 9],
    weight: f64,
    out: &mut [f64; 6],
) {
    for i in 0..3 {
        out[i] = tip[i] - measured[i];
    }
    let rm: &[f64; 9] = measured[3..12].try_into().unwrap_or(&[f64::NAN; 9]);
    let phi = crate::model::rotation::orientation_residual(rm, rot, None);
    for i in 0..3 {
        out[3 + i] = weight * phi[i];
    }
}

/// A residual and its exact derivatives (see [`residual_jacobian`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResidualJacobian {
    /// The [`ConstraintKind::residual_count`] residual components.
    pub r: [f64; 3],
    /// `dx[c*dim + i] = ∂r_c/∂x_i`.
    pub dx: [f64; 9],
    /// `dv[c*nv + v] = ∂r_c/∂values_v` (`nv` = [`ConstraintKind::value_count`]).
    pub dv: [f64; 3 * (MAX_INPUTS - 3)],
}

/// The geometric residual of a tip `x` and its exact derivatives with respect to the tip and
/// to the constraint's values (forward-mode [`Dual`] numbers through [`residual_in`], so
/// they are the derivatives of exactly the function [`geometric_residual`] computes).
#[must_use]
pub fn residual_jacobian(
    kind: ConstraintKind,
    dim: usize,
    values: &[f64],
    x: &[f64],
    measured: &[f64],
) -> ResidualJacobian {
    let nr = kind.residual_count(dim);
    let nv = kind.value_count(dim);
    let mut out = ResidualJacobian {
        r: [0.0; 3],
        dx: [0.0; 9],
        dv: [0.0; 3 * (MAX_INPUTS - 3)],
    };
    if matches!(
        kind,
        ConstraintKind::Point | ConstraintKind::Measured | ConstraintKind::MeasuredPose
    ) {
        // r = x − p (or x − measured): the identity, and −identity in the values. A measured
        // pose's orientation rows are not the tip's: its first 3 rows only.
        for c in 0..nr.min(dim) {
            out.r[c] = x[c]
                - if kind == ConstraintKind::Point {
                    values[c]
                } else {
                    measured[c]
                };
            out.dx[c * dim + c] = 1.0;
            if kind == ConstraintKind::Point {
                out.dv[c * nv + c] = -1.0;
            }
        }
        return out;
    }
    let mut xd = [Dual::constant(0.0); 3];
    for i in 0..dim {
        xd[i] = Dual::input(x[i], i);
    }
    let mut vd = [Dual::constant(0.0); MAX_INPUTS - 3];
    for v in 0..nv {
        vd[v] = Dual::input(values[v], 3 + v);
    }
    let mut res = [Dual::constant(0.0); 3];
    residual_in(kind, dim, &vd[..nv], &xd[..dim], measured, &mut res[..nr]);
    for (c, rc) in res.iter().enumerate().take(nr) {
        out.r[c] = rc.v;
        out.dx[c * dim..(c + 1) * dim].copy_from_slice(&rc.d[..dim]);
        out.dv[c * nv..(c + 1) * nv].copy_from_slice(&rc.d[3..3 + nv]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line3_residual_is_distance_to_line() {
        // Planes x = 1 and y = 2 (b = (-1,0,0), (0,-1/2,0)): the line through (1,2,z).
        let v = [-1.0, 0.0, 0.0, 0.0, -0.5, 0.0];
        let mut r = [0.0; 2];
        geometric_residual(ConstraintKind::Line3, 3, &v, &[4.0, 6.0, 9.0], &[], &mut r);
        let d = libm::sqrt(r[0] * r[0] + r[1] * r[1]);
        assert!((d - 5.0).abs() < 1e-12);
    }

    #[test]
    fn residual_jacobian_matches_central_differences() {
        let cases: [(ConstraintKind, usize, &[f64]); 9] = [
            (ConstraintKind::Point, 3, &[0.1, 0.2, 0.3]),
            (ConstraintKind::Line2, 2, &[-1.7, -0.6]),
            (ConstraintKind::Line3, 3, &[-1.0, 0.2, 0.1, 0.3, -0.5, 0.2]),
            (ConstraintKind::Plane, 3, &[-0.4, 0.3, -3.0]),
            (ConstraintKind::PlaneNormal, 3, &[0.1, -0.2, 0.9, 0.0]),
            (ConstraintKind::Circle, 2, &[0.2, 0.1, 0.3]),
            (ConstraintKind::Sphere, 3, &[0.2, 0.1, -0.1, 0.5]),
            (ConstraintKind::Quadric, 2, &[1.0, 0.3, 0.2, 2.0, -0.5, 0.4]),
            (
                ConstraintKind::Quadric,
                3,
                &[1.0, 0.3, 0.2, 0.1, 2.0, -0.5, 0.4, 0.0, 1.5, 0.2, -0.1, 0.3],
            ),
        ];
        let x = [0.31, -0.42, 0.53];
        let m = [0.3, -0.4, 0.5];
        for (kind, dim, values) in cases {
            let (nr, nv) = (kind.residual_count(dim), kind.value_count(dim));
            let ResidualJacobian { r, dx, dv } =
                residual_jacobian(kind, dim, values, &x[..dim], &m);
            let mut r0 = [0.0; 3];
            geometric_residual(kind, dim, values, &x[..dim], &m, &mut r0);
            let h = 1e-6;
            let fd = |xs: &[f64], vs: &[f64]| {
                let mut o = [0.0; 3];
                geometric_residual(kind, dim, vs, xs, &m, &mut o);
                o
            };
            for c in 0..nr {
                assert!((r[c] - r0[c]).abs() < 1e-15);
                for i in 0..dim {
                    let (mut xp, mut xm) = (x, x);
                    xp[i] += h;
                    xm[i] -= h;
                    let d = (fd(&xp[..dim], values)[c] - fd(&xm[..dim], values)[c]) / (2.0 * h);
                    assert!((d - dx[c * dim + i]).abs() < 1e-7, "{kind:?} dx");
                }
                for v in 0..nv {
                    let (mut vp, mut vm) = (values.to_vec(), values.to_vec());
                    vp[v] += h;
                    vm[v] -= h;
                    let d = (fd(&x[..dim], &vp)[c] - fd(&x[..dim], &vm)[c]) / (2.0 * h);
                    assert!((d - dv[c * nv + v]).abs() < 1e-7, "{kind:?} dv {v}");
                }
            }
        }
    }

    #[test]
    fn plane_normal_residual_is_signed_distance_for_any_scale() {
        // z = 0.5 through n = (0, 0, 2), d = 1: the point (1, 2, 3) is 2.5 above it.
        let mut r = [0.0];
        let x = [1.0, 2.0, 3.0];
        geometric_residual(
            ConstraintKind::PlaneNormal,
            3,
            &[0.0, 0.0, 2.0, 1.0],
            &x,
            &[],
            &mut r,
        );
        assert!((r[0] - 2.5).abs() < 1e-15);
        // Through the origin (d = 0), which `b·x + 1 = 0` cannot write.
        let n = [1.0, -1.0, 0.0, 0.0];
        geometric_residual(ConstraintKind::PlaneNormal, 3, &n, &x, &[], &mut r);
        assert!((r[0] + 1.0 / 2f64.sqrt()).abs() < 1e-15);
        let mut h = [0.0];
        constraint_function(ConstraintKind::PlaneNormal, 3, &n, &x, &mut h);
        assert!((h[0] + 1.0).abs() < 1e-15);
    }

    #[test]
    fn an_offset_is_the_same_for_either_form_of_a_plane() {
        // `b·x + 1 = 0` is the plane by normal `b·x = −1`: every pair of forms agrees.
        use super::{relation_residual_in, Relation, RelationKind};
        let rel = Relation {
            kind: RelationKind::Offset,
            between: [0, 1],
            value: 0.05,
        };
        let (bi, bj) = ([0.3, -0.7, 1.1], [0.6, -1.4, 2.2]);
        let as_normal = |b: [f64; 3]| [b[0], b[1], b[2], -1.0];
        let mut want = [0.0; 4];
        relation_residual_in(&rel, 3, &bi, &bj, &mut want);
        let mut got = [0.0; 4];
        relation_residual_in(&rel, 3, &as_normal(bi), &bj, &mut got);
        assert_eq!(got, want);
        relation_residual_in(&rel, 3, &bi, &as_normal(bj), &mut got);
        assert_eq!(got, want);
        relation_residual_in(&rel, 3, &as_normal(bi), &as_normal(bj), &mut got);
        assert_eq!(got, want);
        // Parallel planes `n·x = 0.2` and `2n·x = 0.9` (`n` of unit length) are 0.25 apart.
        let n = [0.6, 0.0, 0.8];
        let mut r = [0.0; 4];
        let (pi, pj) = ([n[0], n[1], n[2], 0.2], [2.0 * n[0], 0.0, 2.0 * n[2], 0.9]);
        relation_residual_in(&Relation { value: 0.25, ..rel }, 3, &pi, &pj, &mut r);
        assert!(r.iter().all(|x| x.abs() < 1e-15), "{r:?}");
    }

    #[test]
    fn sphere_residual() {
        let v = [1.0, 0.0, 0.0, 2.0];
        let mut r = [0.0];
        geometric_residual(ConstraintKind::Sphere, 3, &v, &[1.0, 3.0, 0.0], &[], &mut r);
        assert!((r[0] - 1.0).abs() < 1e-15);
    }
}

/// What a relation between two constraints of one list states (spec `relations:`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RelationKind {
    /// `‖c_i − c_j‖ = d`: two pinned points, or the centres of two circles or spheres (or a
    /// point and a centre), a known distance apart.
    Distance,
    /// `n_i × n_j = 0` with `n = b/‖b‖` (or `n/‖n‖` for a plane by normal): two planes (two
    /// lines in dim 2) are parallel.
    SameNormal,
    /// Parallel planes (lines in dim 2) a known distance `d` apart: [`RelationKind::SameNormal`]
    /// and `|σ_i − (n_i·n_j) σ_j| = d`, with `σ` a plane's signed offset along its unit normal
    /// `n`: `−1/‖b‖` for `b·x + 1 = 0`, `e/‖a‖` for a plane by normal `a·x = e` (both forms
    /// are `a·x = e`, with `a = b, e = −1` for the first). For two planes `b·x + 1 = 0` this
    /// is `|n_i·n_j/‖b_j‖ − 1/‖b_i‖| = d`.
    Offset,
}

impl RelationKind {
    /// The spec's name of this kind (`distance`, `same_normal`, `offset`).
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            RelationKind::Distance => "distance",
            RelationKind::SameNormal => "same_normal",
            RelationKind::Offset => "offset",
        }
    }

    /// Whether the kind takes a `value` (a distance in metres).
    #[must_use]
    pub const fn has_value(self) -> bool {
        !matches!(self, RelationKind::SameNormal)
    }

    /// Whether a constraint of `kind` can take part: a centre for `distance` (point, circle,
    /// sphere), a normal for the others (plane in either form, 2-D line).
    #[must_use]
    pub const fn accepts(self, kind: ConstraintKind) -> bool {
        match self {
            RelationKind::Distance => matches!(
                kind,
                ConstraintKind::Point | ConstraintKind::Circle | ConstraintKind::Sphere
            ),
            RelationKind::SameNormal | RelationKind::Offset => matches!(
                kind,
                ConstraintKind::Plane | ConstraintKind::PlaneNormal | ConstraintKind::Line2
            ),
        }
    }

    /// Number of residual components of [`relation_residual_in`] in `dim`: 1 for a distance,
    /// the cross product's 3 (1 in the plane) for parallel normals, one more for an offset.
    #[must_use]
    pub const fn residual_count(self, dim: usize) -> usize {
        let cross = if dim == 3 { 3 } else { 1 };
        match self {
            RelationKind::Distance => 1,
            RelationKind::SameNormal => cross,
            RelationKind::Offset => cross + 1,
        }
    }
}

/// A relation between constraints `between[0]` and `between[1]` of a constraint list.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relation {
    /// What is related.
    pub kind: RelationKind,
    /// The two constraint indices (0-based, distinct).
    pub between: [usize; 2],
    /// The distance in metres (`distance`, `offset`); 0 for `same_normal`.
    pub value: f64,
}

/// The residual of a relation, in metres, from the two constraints' values (canonical order,
/// see the module docs): `distance` `‖c_i − c_j‖ − d`; `same_normal` the cross product
/// `n_i × n_j` of the unit normals (one component in the plane), times 1 m; `offset` those
/// and `|σ_i − (n_i·n_j) σ_j| − d` ([`RelationKind::Offset`]; `σ` from [`plane_offset`]).
/// Writes [`RelationKind::residual_count`] values.
pub fn relation_residual_in<T: Real>(
    relation: &Relation,
    dim: usize,
    vi: &[T],
    vj: &[T],
    out: &mut [T],
) {
    match relation.kind {
        RelationKind::Distance => {
            let mut s = T::constant(0.0);
            for k in 0..dim {
                let d = vi[k] - vj[k];
                s = s + d * d;
            }
            // Coincident points: the norm has no derivative there (0/0); its value 0 with a
            // zero gradient keeps NaN out of every solver (the fits start the points apart,
            // from their own poses, see `fit::start`).
            let norm = if s.value() > 0.0 {
                s.sqrt()
            } else {
                T::constant(0.0)
            };
            out[0] = norm - T::constant(relation.value);
        }
        RelationKind::SameNormal | RelationKind::Offset => {
            let m = if dim == 3 { 3 } else { 2 };
            let (bi, bj) = (&vi[..m], &vj[..m]);
            let ni = dot_r(bi, bi).sqrt();
            let nj = dot_r(bj, bj).sqrt();
            let u: [T; 3] =
                core::array::from_fn(|k| if k < m { bi[k] / ni } else { T::constant(0.0) });
            let w: [T; 3] =
                core::array::from_fn(|k| if k < m { bj[k] / nj } else { T::constant(0.0) });
            let cross = if dim == 3 { 3 } else { 1 };
            if dim == 3 {
                out[0] = u[1] * w[2] - u[2] * w[1];
                out[1] = u[2] * w[0] - u[0] * w[2];
                out[2] = u[0] * w[1] - u[1] * w[0];
            } else {
                out[0] = u[0] * w[1] - u[1] * w[0];
            }
            if relation.kind == RelationKind::Offset {
                let s = plane_offset(vi, m, ni) - dot_r(&u[..m], &w[..m]) * plane_offset(vj, m, nj);
                let abs = if s.value() < 0.0 {
                    T::constant(0.0) - s
                } else {
                    s
                };
                out[cross] = abs - T::constant(relation.value);
            }
        }
    }
}
