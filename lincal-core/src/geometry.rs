//! Constraint geometry, numeric and `no_std`: the constraint function `h(x)` the symbolic engine
//! expands, and the geometric residual (distance of a tip from the constraint) that refinement
//! minimises. Both model sources (derived and run-time) call these, so they agree by
//! construction.
//!
//! Constraint values come in the canonical order of [`ConstraintKind::value_count`]:
//! point `p`; 2-D line `b`; 3-D line `b₁, b₂`; plane `b`; circle and sphere `center, r`;
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
    /// Circle `‖x − c‖ = r`.
    Circle,
    /// Sphere `‖x − c‖ = r`.
    Sphere,
    /// Quadric `xᵀAx + bᵀx + 1 = 0`.
    Quadric,
    /// Measured tip: `x` is given by the data.
    Measured,
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
            ConstraintKind::Circle | ConstraintKind::Sphere => dim + 1,
            ConstraintKind::Quadric => dim * dim + dim,
            ConstraintKind::Measured => 0,
        }
    }

    /// Number of scalar equations `h_e(x) = 0` a tip on this constraint satisfies
    /// (for `Measured`, the `dim` coordinates regressed on the basis).
    #[must_use]
    pub const fn equation_count(self, dim: usize) -> usize {
        match self {
            ConstraintKind::Point | ConstraintKind::Measured => dim,
            ConstraintKind::Line3 => 2,
            _ => 1,
        }
    }

    /// Number of geometric residual components per pose.
    #[must_use]
    pub const fn residual_count(self, dim: usize) -> usize {
        match self {
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
            ConstraintKind::Plane => "plane",
            ConstraintKind::Circle => "circle",
            ConstraintKind::Sphere => "sphere",
            ConstraintKind::Quadric => "quadric",
            ConstraintKind::Measured => "measured",
        }
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The constraint function(s) `h(x)`, exactly the polynomials the symbolic engine expands:
/// point `x − p`; line and plane `b·x + 1`; 3-D line both planes; circle and sphere
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
        ConstraintKind::Measured => out[..dim].copy_from_slice(&x[..dim]),
    }
}

/// Geometric residual of a tip `x` from the constraint, in metres:
/// point `x − p`; line and plane the signed distance `(b·x + 1)/‖b‖`; 3-D line the two
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
    match kind {
        ConstraintKind::Point => {
            for i in 0..dim {
                out[i] = x[i] - values[i];
            }
        }
        ConstraintKind::Line2 | ConstraintKind::Plane => {
            let n = libm::sqrt(dot(values, values));
            out[0] = (dot(values, x) + 1.0) / n;
        }
        ConstraintKind::Line3 => {
            let (b1, b2) = (&values[0..3], &values[3..6]);
            let n1 = libm::sqrt(dot(b1, b1));
            let r1 = (dot(b1, x) + 1.0) / n1;
            // u2 = b2 with its component along u1 = b1/|b1| removed.
            let along = dot(b2, b1) / n1;
            let mut perp = [0.0; 3];
            for i in 0..3 {
                perp[i] = b2[i] - along * b1[i] / n1;
            }
            let n2 = libm::sqrt(dot(&perp, &perp));
            out[0] = r1;
            out[1] = ((dot(b2, x) + 1.0) - along * r1) / n2;
        }
        ConstraintKind::Circle | ConstraintKind::Sphere => {
            let mut s = 0.0;
            for i in 0..dim {
                let d = x[i] - values[i];
                s += d * d;
            }
            out[0] = libm::sqrt(s) - values[dim];
        }
        ConstraintKind::Quadric => {
            let mut h = [0.0];
            constraint_function(kind, dim, values, x, &mut h);
            let mut g2 = 0.0;
            for i in 0..dim {
                // ∇h = (A + Aᵀ)x + b
                let mut g = values[dim * dim + i];
                for j in 0..dim {
                    g += (values[i * dim + j] + values[j * dim + i]) * x[j];
                }
                g2 += g * g;
            }
            out[0] = h[0] / libm::sqrt(g2);
        }
        ConstraintKind::Measured => {
            for i in 0..dim {
                out[i] = x[i] - measured[i];
            }
        }
    }
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
    fn sphere_residual() {
        let v = [1.0, 0.0, 0.0, 2.0];
        let mut r = [0.0];
        geometric_residual(ConstraintKind::Sphere, 3, &v, &[1.0, 3.0, 0.0], &[], &mut r);
        assert!((r[0] - 1.0).abs() < 1e-15);
    }
}
