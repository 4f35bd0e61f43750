//! Rotations for full-pose measurements, numeric and `no_std`: unit quaternions, rotation
//! vectors and matrices, and the exact derivative of the orientation residual.
//!
//! A rotation matrix is stored column-major as 9 values, `r[3c + i] = R_ic`: column `c` is the
//! frame's axis `c` in world coordinates (the layout of a measured pose's row, after `x, y, z`).
//!
//! # The orientation residual
//! For a measured rotation `R_m` and a predicted `R(p)`, the residual is the rotation vector
//! `φ = log(R_mᵀ·R(p))` (radians, in the measured tool frame). A parameter whose change turns
//! the tool frame by the world angular velocity `ω` changes `R` to `exp([ω]ₓ)·R`, so
//! `R_mᵀR` to `R_mᵀR·exp([Rᵀω]ₓ)`, and (right Jacobian of SO(3))
//!
//! `∂φ/∂p = J_r⁻¹(φ)·Rᵀ·ω`,
//! `J_r⁻¹(φ) = I + ½[φ]ₓ + (1/θ² − (1 + cos θ)/(2θ sin θ))·[φ]ₓ²`, `θ = ‖φ‖`,
//!
//! exactly, not the small-residual approximation `J_r⁻¹ ≈ I`.

/// Tolerance on a measured quaternion's norm: `|‖q‖ − 1|` beyond it is refused as not a unit
/// quaternion (printed quaternions of 6 significant digits are within `1e-5`); within it the
/// quaternion is normalised.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// The largest angle (radians) a measured rotation vector may turn by: a full turn (a writer
/// gives at most π); beyond it the vector is read as degrees and refused, in a CSV and from
/// Python alike.
pub const MAX_ROTATION_VECTOR: f64 = 2.0 * core::f64::consts::PI + 1e-9;

fn sqrt(v: f64) -> f64 {
    libm::sqrt(v)
}

/// The rotation matrix (column-major) of the unit quaternion `w, x, y, z` (scalar first);
/// the quaternion is normalised first, so any nonzero quaternion gives a rotation.
#[must_use]
pub fn matrix_from_quaternion(q: [f64; 4]) -> [f64; 9] {
    let n = sqrt(q.iter().map(|v| v * v).sum());
    let [w, x, y, z] = q.map(|v| v / n);
    // Row-major entries of the standard formula, then stored by columns.
    let r00 = 1.0 - 2.0 * (y * y + z * z);
    let r01 = 2.0 * (x * y - w * z);
    let r02 = 2.0 * (x * z + w * y);
    let r10 = 2.0 * (x * y + w * z);
    let r11 = 1.0 - 2.0 * (x * x + z * z);
    let r12 = 2.0 * (y * z - w * x);
    let r20 = 2.0 * (x * z - w * y);
    let r21 = 2.0 * (y * z + w * x);
    let r22 = 1.0 - 2.0 * (x * x + y * y);
    [r00, r10, r20, r01, r11, r21, r02, r12, r22]
}

/// The unit quaternion `w, x, y, z` of a rotation matrix (column-major), with `w ≥ 0`
/// (Shepperd's method: the largest of the four squares is taken first, so it is accurate for
/// every rotation, half-turns included).
#[must_use]
pub fn quaternion_from_matrix(r: &[f64; 9]) -> [f64; 4] {
    let m = |i: usize, c: usize| r[3 * c + i];
    let tr = m(0, 0) + m(1, 1) + m(2, 2);
    let q = if tr >= m(0, 0) && tr >= m(1, 1) && tr >= m(2, 2) {
        let s = 2.0 * sqrt(1.0 + tr);
        [
            s / 4.0,
            (m(2, 1) - m(1, 2)) / s,
            (m(0, 2) - m(2, 0)) / s,
            (m(1, 0) - m(0, 1)) / s,
        ]
    } else if m(0, 0) >= m(1, 1) && m(0, 0) >= m(2, 2) {
        let s = 2.0 * sqrt(1.0 + m(0, 0) - m(1, 1) - m(2, 2));
        [
            (m(2, 1) - m(1, 2)) / s,
            s / 4.0,
            (m(0, 1) + m(1, 0)) / s,
            (m(0, 2) + m(2, 0)) / s,
        ]
    } else if m(1, 1) >= m(2, 2) {
        let s = 2.0 * sqrt(1.0 + m(1, 1) - m(0, 0) - m(2, 2));
        [
            (m(0, 2) - m(2, 0)) / s,
            (m(0, 1) + m(1, 0)) / s,
            s / 4.0,
            (m(1, 2) + m(2, 1)) / s,
        ]
    } else {
        let s = 2.0 * sqrt(1.0 + m(2, 2) - m(0, 0) - m(1, 1));
        [
            (m(1, 0) - m(0, 1)) / s,
            (m(0, 2) + m(2, 0)) / s,
            (m(1, 2) + m(2, 1)) / s,
            s / 4.0,
        ]
    };
    let n = sqrt(q.iter().map(|v| v * v).sum());
    let sign = if q[0] < 0.0 { -1.0 } else { 1.0 };
    q.map(|v| sign * v / n)
}

/// The rotation matrix (column-major) of the rotation vector `φ` (axis times angle, radians):
/// Rodrigues' formula `R = I + (sin θ/θ)[φ]ₓ + ((1 − cos θ)/θ²)[φ]ₓ²`.
#[must_use]
pub fn matrix_from_rotation_vector(phi: [f64; 3]) -> [f64; 9] {
    let t = sqrt(phi.iter().map(|v| v * v).sum());
    let half = t / 2.0;
    // The quaternion (cos θ/2, sin(θ/2)/θ · φ), with sin(θ/2)/θ by its series near 0.
    let k = if t < 1e-8 {
        0.5 - t * t / 48.0
    } else {
        libm::sin(half) / t
    };
    matrix_from_quaternion([libm::cos(half), k * phi[0], k * phi[1], k * phi[2]])
}

/// The rotation vector (axis times angle in `[0, π]`) of a rotation matrix (column-major),
/// through its quaternion (accurate for small angles and half-turns alike).
#[must_use]
pub fn rotation_vector(r: &[f64; 9]) -> [f64; 3] {
    let [w, x, y, z] = quaternion_from_matrix(r);
    let s = sqrt(x * x + y * y + z * z);
    // θ = 2·atan2(s, w); φ = θ/s · (x, y, z), with θ/s → 2/w near the identity.
    let k = if s < 1e-12 {
        2.0 / w
    } else {
        2.0 * libm::atan2(s, w) / s
    };
    [k * x, k * y, k * z]
}

/// The rotation angle of a rotation matrix (column-major), in `[0, π]`.
#[must_use]
pub fn angle(r: &[f64; 9]) -> f64 {
    let v = rotation_vector(r);
    sqrt(v.iter().map(|a| a * a).sum())
}

/// `Aᵀ·B` for column-major 3×3 matrices.
#[must_use]
pub fn transpose_times(a: &[f64; 9], b: &[f64; 9]) -> [f64; 9] {
    let mut out = [0.0; 9];
    for c in 0..3 {
        for i in 0..3 {
            // (AᵀB)_ic = column i of A · column c of B.
            out[3 * c + i] = (0..3).map(|k| a[3 * i + k] * b[3 * c + k]).sum();
        }
    }
    out
}

/// `J_r⁻¹(φ)`, row-major 3×3: the inverse right Jacobian of SO(3) at the rotation vector `φ`
/// (see the module docs), by its series near `θ = 0`.
#[must_use]
pub fn right_jacobian_inverse(phi: [f64; 3]) -> [[f64; 3]; 3] {
    let t2 = phi.iter().map(|v| v * v).sum::<f64>();
    let t = sqrt(t2);
    // 1/θ² − (1 + cos θ)/(2θ sin θ) → 1/12 + θ²/720 as θ → 0.
    let k = if t < 1e-4 {
        1.0 / 12.0 + t2 / 720.0
    } else {
        1.0 / t2 - (1.0 + libm::cos(t)) / (2.0 * t * libm::sin(t))
    };
    let [a, b, c] = phi;
    // [φ]ₓ and [φ]ₓ² = φφᵀ − θ² I.
    let s = [[0.0, -c, b], [c, 0.0, -a], [-b, a, 0.0]];
    let mut out = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let sq = phi[i] * phi[j] - if i == j { t2 } else { 0.0 };
            out[i][j] = if i == j { 1.0 } else { 0.0 } + 0.5 * s[i][j] + k * sq;
        }
    }
    out
}

/// The orientation residual `φ = log(R_mᵀ·R)` of a predicted rotation `r` against a measured
/// one `measured` (both column-major), and, when `omega` gives the world angular velocities
/// of the tool frame for `P` parameters (`omega[i*P + j] = ω_{j,i}`), its derivative
/// `∂φ/∂p = J_r⁻¹(φ)·Rᵀ·ω` into `dphi` (`3 × P`, row-major).
pub fn orientation_residual(
    measured: &[f64; 9],
    r: &[f64; 9],
    omega: Option<(&[f64], &mut [f64])>,
) -> [f64; 3] {
    let phi = rotation_vector(&transpose_times(measured, r));
    if let Some((omega, dphi)) = omega {
        let np = omega.len() / 3;
        let jinv = right_jacobian_inverse(phi);
        // M = J_r⁻¹·Rᵀ (row-major): (Rᵀ)_kl = R_lk = r[3k + l].
        let mut m = [[0.0; 3]; 3];
        for (i, row) in m.iter_mut().enumerate() {
            for (l, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| jinv[i][k] * r[3 * k + l]).sum();
            }
        }
        for j in 0..np {
            let w = [omega[j], omega[np + j], omega[2 * np + j]];
            for i in 0..3 {
                dphi[i * np + j] = m[i][0] * w[0] + m[i][1] * w[1] + m[i][2] * w[2];
            }
        }
    }
    phi
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_vector(rng: &mut ChaCha8Rng, max_angle: f64) -> [f64; 3] {
        let axis: [f64; 3] = core::array::from_fn(|_| rng.gen_range(-1.0..1.0));
        let n = sqrt(axis.iter().map(|v| v * v).sum());
        let a = rng.gen_range(0.0..max_angle);
        axis.map(|v| v / n * a)
    }

    #[test]
    fn quaternion_matrix_and_rotation_vector_round_trip() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for k in 0..500 {
            // Include angles up to π and tiny ones.
            let max = if k % 5 == 0 {
                1e-9
            } else {
                core::f64::consts::PI
            };
            let phi = random_vector(&mut rng, max);
            let r = matrix_from_rotation_vector(phi);
            // Orthonormal with determinant 1.
            let rtr = transpose_times(&r, &r);
            for c in 0..3 {
                for i in 0..3 {
                    let e = if i == c { 1.0 } else { 0.0 };
                    assert!((rtr[3 * c + i] - e).abs() < 1e-14);
                }
            }
            let back = rotation_vector(&r);
            for i in 0..3 {
                assert!((back[i] - phi[i]).abs() < 1e-12, "{phi:?} -> {back:?}");
            }
            let q = quaternion_from_matrix(&r);
            let r2 = matrix_from_quaternion(q);
            for i in 0..9 {
                assert!((r2[i] - r[i]).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn orientation_derivative_matches_central_differences() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for k in 0..100 {
            // Residual angles from tiny to large (up to 2.5 rad).
            let max = if k % 3 == 0 { 1e-3 } else { 2.5 };
            let rm = matrix_from_rotation_vector(random_vector(&mut rng, core::f64::consts::PI));
            let delta = matrix_from_rotation_vector(random_vector(&mut rng, max));
            // R = R_m·Δ, then perturbed by world rotations about two directions.
            let mut r = [0.0; 9];
            for c in 0..3 {
                for i in 0..3 {
                    r[3 * c + i] = (0..3).map(|k| rm[3 * k + i] * delta[3 * c + k]).sum();
                }
            }
            let omega: Vec<f64> = (0..6).map(|_| rng.gen_range(-1.0..1.0)).collect();
            // omega[i*2 + j]: two parameters.
            let mut d = [0.0; 6];
            orientation_residual(&rm, &r, Some((&omega, &mut d)));
            for j in 0..2 {
                let w = [omega[j], omega[2 + j], omega[4 + j]];
                let h = 1e-6;
                let turned = |s: f64| {
                    let e = matrix_from_rotation_vector(w.map(|v| v * s));
                    let mut out = [0.0; 9];
                    for c in 0..3 {
                        for i in 0..3 {
                            out[3 * c + i] = (0..3).map(|k| e[3 * k + i] * r[3 * c + k]).sum();
                        }
                    }
                    orientation_residual(&rm, &out, None)
                };
                let (p, m) = (turned(h), turned(-h));
                for i in 0..3 {
                    let fd = (p[i] - m[i]) / (2.0 * h);
                    assert!((fd - d[i * 2 + j]).abs() < 1e-7, "{fd} vs {}", d[i * 2 + j]);
                }
            }
        }
    }
}
