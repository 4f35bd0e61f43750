//! What the user asks of the weak-direction prior ([`super`]): whether it is on, its shape,
//! and how large it is (relative to the data, or fixed tolerances).

/// The default weight of the prior against the data ([`PriorScale::Weight`]): `10⁻⁴`, MUKCa's
/// (1 m ≡ 1 rad). A joint mounting misplaced by 1 mm (or 1 mrad) must buy 10 µm of RMS
/// residual per pose.
pub const DEFAULT_PRIOR_WEIGHT: f64 = 1e-4;

/// Default tolerance (one standard deviation of the prior) of a length of the arm when
/// tolerances are given ([`PriorScale::Tolerances`]) but this one is not: 1 cm. With the
/// default shape ([`PriorShape::Frames`]), the std of each joint's mounting translation.
pub const DEFAULT_LENGTH_TOLERANCE: f64 = 0.01;

/// Default tolerance of an angle of the arm when tolerances are given but this one is not:
/// 0.01 rad (0.57°). With the default shape, the std of each joint's mounting rotation.
pub const DEFAULT_ANGLE_TOLERANCE: f64 = 0.01;

/// What the prior's tolerances are tolerances of.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum PriorShape {
    /// Each joint's mounting is misplaced by a small rigid motion (the default; module docs).
    #[default]
    Frames,
    /// Each arm parameter on its own: `p_j ~ N(nominal_j, τ_j²)`.
    Params,
}

/// How large the prior is (module docs, *How large*).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PriorScale {
    /// Relative to the data (the default, [`DEFAULT_PRIOR_WEIGHT`]): the fit minimises
    /// `(1/N)·Σ_l ‖g_l‖² + w·‖ξ‖²`, the mean squared residual per pose and `w` times the
    /// squared misplacement (metres and radians, 1 m ≡ 1 rad), so the tolerances are
    /// `τ_l = τ_a = σ̂/√(N·w)` (`σ̂` the noise level per residual component, `N` the poses).
    Weight(f64),
    /// Fixed tolerances, one standard deviation: lengths (metres) and angles (radians). A
    /// Bayesian prior that fades as poses are added.
    Tolerances {
        /// Lengths (metres).
        length: f64,
        /// Angles (radians).
        angle: f64,
    },
}

impl PriorScale {
    /// The tolerances `(length, angle)` for a fit of `poses` poses whose noise level per
    /// residual component is `sigma`: [`PriorScale::Weight`]'s `σ̂/√(N·w)` for both, or the
    /// fixed ones.
    #[must_use]
    pub fn tolerances(self, sigma: f64, poses: usize) -> (f64, f64) {
        match self {
            PriorScale::Weight(w) => {
                let t = sigma / (poses.max(1) as f64 * w).sqrt();
                (t, t)
            }
            PriorScale::Tolerances { length, angle } => (length, angle),
        }
    }
}

/// Whether the fit may use the prior, and how large it is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PriorChoice {
    /// Never: weak directions are left free (and warned about).
    Off,
    /// When a direction is weak.
    On {
        /// How large.
        scale: PriorScale,
        /// Of what.
        shape: PriorShape,
    },
}

impl Default for PriorChoice {
    fn default() -> Self {
        PriorChoice::On {
            scale: PriorScale::Weight(DEFAULT_PRIOR_WEIGHT),
            shape: PriorShape::Frames,
        }
    }
}

impl PriorChoice {
    /// The frame prior with fixed tolerances: lengths `length` (metres), angles `angle`
    /// (radians), a Bayesian prior that fades as poses are added. The one for data with no
    /// model error (simulated), or when the arm's tolerances are known.
    #[must_use]
    pub fn fixed(length: f64, angle: f64) -> PriorChoice {
        PriorChoice::On {
            scale: PriorScale::Tolerances { length, angle },
            shape: PriorShape::Frames,
        }
    }

    /// The same prior with its tolerances fixed for a fit of `poses` poses at noise level
    /// `sigma` ([`PriorScale::tolerances`]).
    #[must_use]
    pub fn resolved(self, sigma: f64, poses: usize) -> PriorChoice {
        match self {
            PriorChoice::On { scale, shape } => {
                let (length, angle) = scale.tolerances(sigma, poses);
                PriorChoice::On {
                    scale: PriorScale::Tolerances { length, angle },
                    shape,
                }
            }
            PriorChoice::Off => PriorChoice::Off,
        }
    }

    /// The weight of a relative prior ([`PriorScale::Weight`]), `None` otherwise.
    #[must_use]
    pub fn weight(self) -> Option<f64> {
        match self {
            PriorChoice::On {
                scale: PriorScale::Weight(w),
                ..
            } => Some(w),
            _ => None,
        }
    }
}
