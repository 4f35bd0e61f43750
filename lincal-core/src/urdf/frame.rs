//! Rigid transforms in `f64`: the little algebra the URDF import and export need.
//!
//! A transform `T = (R, t)` maps a point `x` of its child frame to `R·x + t` in its parent
//! frame; `R` is stored by rows. URDF's `<origin xyz rpy>` is `Tr(xyz)·Rz(y)·Ry(p)·Rx(r)`,
//! the same angles as the spec's `base` (`roll, pitch, yaw`).

/// A rigid transform `x ↦ R·x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Iso {
    /// Rotation, by rows.
    pub r: [[f64; 3]; 3],
    /// Translation.
    pub t: [f64; 3],
}

/// `a·b`.
#[must_use]
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
#[must_use]
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a + s·b`.
#[must_use]
pub fn axpy(a: [f64; 3], s: f64, b: [f64; 3]) -> [f64; 3] {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

/// `‖a‖`.
#[must_use]
pub fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// `a / ‖a‖` (the caller checks that `a` is not zero).
#[must_use]
pub fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a);
    [a[0] / n, a[1] / n, a[2] / n]
}

impl Iso {
    /// The identity.
    pub const IDENTITY: Iso = Iso {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: [0.0; 3],
    };

    /// A pure translation.
    #[must_use]
    pub fn translation(t: [f64; 3]) -> Iso {
        Iso { t, ..Iso::IDENTITY }
    }

    /// The rotation by `angle` about the unit vector `u` (Rodrigues:
    /// `R = cos·I + sin·[u]ₓ + (1 − cos)·u uᵀ`).
    #[must_use]
    pub fn rotation(u: [f64; 3], angle: f64) -> Iso {
        let (s, c) = angle.sin_cos();
        let v = 1.0 - c;
        let [x, y, z] = u;
        Iso {
            r: [
                [c + x * x * v, x * y * v - z * s, x * z * v + y * s],
                [y * x * v + z * s, c + y * y * v, y * z * v - x * s],
                [z * x * v - y * s, z * y * v + x * s, c + z * z * v],
            ],
            t: [0.0; 3],
        }
    }

    /// `Tr(xyz)·Rz(rpy[2])·Ry(rpy[1])·Rx(rpy[0])`: a URDF `<origin>`, or the spec's `base`.
    #[must_use]
    pub fn from_xyz_rpy(xyz: [f64; 3], rpy: [f64; 3]) -> Iso {
        let rz = Iso::rotation([0.0, 0.0, 1.0], rpy[2]);
        let ry = Iso::rotation([0.0, 1.0, 0.0], rpy[1]);
        let rx = Iso::rotation([1.0, 0.0, 0.0], rpy[0]);
        Iso::translation(xyz).mul(&rz).mul(&ry).mul(&rx)
    }

    /// The frame with axes `x, y, z` (columns of `R`, unit and right-handed) at `o`.
    #[must_use]
    pub fn from_axes(x: [f64; 3], y: [f64; 3], z: [f64; 3], o: [f64; 3]) -> Iso {
        Iso {
            r: [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]],
            t: o,
        }
    }

    /// Column `c` of `R`: axis `c` of the frame in parent coordinates.
    #[must_use]
    pub fn axis(&self, c: usize) -> [f64; 3] {
        [self.r[0][c], self.r[1][c], self.r[2][c]]
    }

    /// `self·other`.
    #[must_use]
    pub fn mul(&self, o: &Iso) -> Iso {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..3).map(|k| self.r[i][k] * o.r[k][j]).sum();
            }
        }
        Iso {
            r,
            t: self.apply(o.t),
        }
    }

    /// `R·v` (a direction).
    #[must_use]
    pub fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        [dot(self.r[0], v), dot(self.r[1], v), dot(self.r[2], v)]
    }

    /// `R·x + t` (a point).
    #[must_use]
    pub fn apply(&self, x: [f64; 3]) -> [f64; 3] {
        let v = self.rotate(x);
        [v[0] + self.t[0], v[1] + self.t[1], v[2] + self.t[2]]
    }

    /// The inverse `(Rᵀ, −Rᵀt)`.
    #[must_use]
    pub fn inverse(&self) -> Iso {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = self.r[j][i];
            }
        }
        let inv = Iso { r, t: [0.0; 3] };
        let t = inv.rotate(self.t);
        Iso {
            r,
            t: [-t[0], -t[1], -t[2]],
        }
    }

    /// Roll, pitch, yaw with `R = Rz(yaw)·Ry(pitch)·Rx(roll)`, pitch in `[−π/2, π/2]`
    /// (at `|pitch| = π/2` the roll is 0 and the yaw takes the whole turn about z).
    #[must_use]
    pub fn rpy(&self) -> [f64; 3] {
        let r = &self.r;
        let cp = r[0][0].hypot(r[1][0]);
        let pitch = (-r[2][0]).atan2(cp);
        if cp > 1e-12 {
            // The roll from `Rz(−yaw)·R = Ry(pitch)·Rx(roll)`, whose middle row is
            // `(0, cos roll, −sin roll)`: entries of order one, so that near the gimbal lock
            // (where `r21, r22` are both of order `cos pitch`, and the yaw itself is barely
            // determined) the roll makes up for the yaw's rounding and the product is `R`
            // to the last digits. Read off `r21, r22` directly, a pitch 3·10⁻⁸ from π/2 wrote
            // a URDF whose tip was 2.6·10⁻⁸ m off.
            let yaw = r[1][0].atan2(r[0][0]);
            let (sy, cy) = yaw.sin_cos();
            let m11 = -sy * r[0][1] + cy * r[1][1];
            let m12 = -sy * r[0][2] + cy * r[1][2];
            [(-m12).atan2(m11), pitch, yaw]
        } else {
            // Gimbal lock: R = Rz(yaw)·Ry(±π/2)·Rx(roll) depends on yaw ∓ roll only.
            [0.0, pitch, (-r[0][1]).atan2(r[1][1])]
        }
    }

    /// The largest difference of rotation entries and of translation entries from `o`.
    #[must_use]
    pub fn distance(&self, o: &Iso) -> (f64, f64) {
        let mut dr: f64 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                dr = dr.max((self.r[i][j] - o.r[i][j]).abs());
            }
        }
        let dt = (0..3).fold(0.0_f64, |m, i| m.max((self.t[i] - o.t[i]).abs()));
        (dr, dt)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rpy_round_trips_and_matches_the_product() {
        for rpy in [
            [0.1, -0.7, 2.9],
            [-3.0, 1.2, -0.4],
            [0.0, core::f64::consts::FRAC_PI_2, 0.3],
            [0.0, -core::f64::consts::FRAC_PI_2, -1.3],
        ] {
            let t = Iso::from_xyz_rpy([1.0, 2.0, 3.0], rpy);
            let back = Iso::from_xyz_rpy(t.t, t.rpy());
            let (dr, dt) = t.distance(&back);
            assert!(dr < 1e-14 && dt == 0.0, "{rpy:?}: {dr}");
        }
    }

    /// Near the gimbal lock (a pitch within 10⁻⁴ to 10⁻¹¹ of ±π/2, a URDF's rounded
    /// `1.5707963`), the rpy read off a frame rebuilds it to rounding: the roll is taken with
    /// the yaw removed, not on its own.
    #[test]
    fn rpy_near_the_gimbal_lock_rebuilds_the_frame() {
        let h = core::f64::consts::FRAC_PI_2;
        for (k, eps) in [1e-4, 3e-6, 2.7e-8, 1e-9, 5e-11].into_iter().enumerate() {
            for sign in [1.0, -1.0] {
                let rpy = [
                    0.7 - 0.3 * k as f64,
                    sign * (h - eps),
                    -1.1 + 0.5 * k as f64,
                ];
                let t = Iso::from_xyz_rpy([0.0; 3], rpy);
                let back = Iso::from_xyz_rpy([0.0; 3], t.rpy());
                let (dr, _) = t.distance(&back);
                assert!(dr < 4e-16, "{rpy:?}: {dr}");
            }
        }
    }

    #[test]
    fn inverse_and_rotation() {
        let t = Iso::from_xyz_rpy([0.3, -0.2, 0.5], [0.4, 0.5, -0.6]);
        let (dr, dt) = t.mul(&t.inverse()).distance(&Iso::IDENTITY);
        assert!(dr < 1e-15 && dt < 1e-15);
        let r = Iso::rotation(unit([1.0, 2.0, -0.5]), 0.7);
        let a = r.rotate([0.0, 0.0, 1.0]);
        assert!((norm(a) - 1.0).abs() < 1e-15);
        // A quarter turn about z takes x to y.
        let q =
            Iso::rotation([0.0, 0.0, 1.0], core::f64::consts::FRAC_PI_2).rotate([1.0, 0.0, 0.0]);
        assert!((q[1] - 1.0).abs() < 1e-15 && q[0].abs() < 1e-15);
    }
}
