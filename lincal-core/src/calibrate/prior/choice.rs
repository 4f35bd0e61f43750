//! What the user asks of the weak-direction prior ([`super`]): whether it is on, its shape,
//! and how large it is (relative to the data, or fixed tolerances).

/// MUKCa's weight of a relative prior against the data ([`PriorScale::Weight`]): `10⁻⁴`
/// (1 m ≡ 1 rad); the default before the data chose the strength ([`PriorScale::Auto`]). A joint mounting misplaced by 1 mm (or 1 mrad) must buy 10 µm of RMS
/// residual per pose.
pub const DEFAULT_PRIOR_WEIGHT: f64 = 1e-4;

/// Default tolerance (one standard deviation of the prior) of a length of the arm when
/// tolerances are given ([`PriorScale::Tolerances`]) but this one is not: 1 cm. With the
/// default shape ([`PriorShape::Frames`]), the std of each joint's mounting translation.
pub const DEFAULT_LENGTH_TOLERANCE: f64 = 0.01;

/// Default tolerance of an angle of the arm when tolerances are given but this one is not:
/// 0.01 rad (0.57°). With the default shape, the std of each joint's mounting rotation.
pub const DEFAULT_ANGLE_TOLERANCE: f64 = 0.01;

/// The tolerances accepted (`--tolerance-length`, `--tolerance-angle`; metres, radians):
/// from 1 nm (1 nrad) to 1 km (1000 rad). Below, the prior's squared information leaves the
/// range where the fit's factorisation keeps the data's digits; above, it is no prior.
pub const TOLERANCE_RANGE: (f64, f64) = (1e-9, 1e3);

/// The weights accepted (`--prior-weight`), from `10⁻¹²` to `10⁶`, for the same reason.
pub const WEIGHT_RANGE: (f64, f64) = (1e-12, 1e6);

/// `v` checked against `range`: `None` when accepted, else what is wrong with it.
#[must_use]
pub fn out_of_range(v: f64, range: (f64, f64)) -> Option<String> {
    if v.is_finite() && v >= range.0 && v <= range.1 {
        None
    } else {
        // `{:e}`: a subnormal written out in full is 320 digits.
        Some(format!(
            "{v:e} is outside the accepted range {:e} to {:e}",
            range.0, range.1
        ))
    }
}

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
    /// Chosen from the data at every run (the default; [`super::strength`]): one scale for
    /// every joint mounting, or each direction by its own evidence, whichever does best on
    /// poses its fit did not see (grouped cross-validation). Its information does not grow
    /// with the poses, so with enough data the fit becomes the plain least-squares fit.
    Auto,
    /// Relative to the data (`--prior-weight`; [`DEFAULT_PRIOR_WEIGHT`] was the default
    /// before the data chose): the fit minimises
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
            // Before the data choose, the default tolerances (pose selection plans with them).
            PriorScale::Auto => (DEFAULT_LENGTH_TOLERANCE, DEFAULT_ANGLE_TOLERANCE),
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
    /// On every direction of the arm, in proportion to what the data leave unknown there.
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
            scale: PriorScale::Auto,
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
