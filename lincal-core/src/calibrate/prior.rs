//! The weak-direction default: a Gaussian prior on the arm's parameters around their
//! nominals, used only when the data leave a direction weak.
//!
//! A real arm's data often barely see some directions: the `d` offsets along parallel axes
//! (only their sum moves the tip), the tool length against the last link's, a wrist offset at
//! a pinned point. Left free, the fit moves them by metres for a micrometre of residual, and
//! the answer then depends on rounding (the order of `params:`) and generalises badly to
//! other placements. The maker's drawing knows these lengths to millimetres.
//!
//! So, after the unregularised fit, every free parameter of the arm (a joint slot `a`,
//! `alpha`, `d`, `home`, `theta`, `offset`, or a tool entry; not the base frame, not a
//! constraint's own value) has a tolerance `τ_j` ([`PriorChoice`], default
//! [`DEFAULT_LENGTH_TOLERANCE`] for lengths and [`DEFAULT_ANGLE_TOLERANCE`] for angles).
//! When one of them has a standard deviation above its tolerance (or none: the data do not
//! determine it), the fit is run again from the estimate with the prior rows
//! `(σ̂/τ_j)·(p_j − nominal_j)` added ([`CalibModel::prior_weight`]), `σ̂` the
//! unregularised fit's noise level `sqrt(Σ‖g‖²/(m − n))`: the maximum a posteriori estimate
//! `argmin Σ‖g_l‖²/σ̂² + Σ_j ((p_j − nominal_j)/τ_j)²`. Directions the data determine well
//! (standard deviation `s ≪ τ`) move by a fraction `s²/τ²` of their error at most; weak
//! ones stay within about `τ` of the nominal. The reported standard deviations are the
//! posterior ones. When no parameter is weak the prior is not applied and the result is the
//! unregularised fit's, unchanged.

use crate::data::Poses;
use crate::fit::start::DataStart;
use crate::model::CalibModel;
use crate::spec::Spec;

/// Default tolerance (one standard deviation of the prior) of a length of the arm: 1 cm.
pub const DEFAULT_LENGTH_TOLERANCE: f64 = 0.01;

/// Default tolerance of an angle of the arm (a twist, a home offset): 0.02 rad (1.15°).
pub const DEFAULT_ANGLE_TOLERANCE: f64 = 0.02;

/// Whether the fit may use the prior, and the tolerances (one standard deviation) of the
/// arm's lengths (metres) and angles (radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PriorChoice {
    /// Never: weak directions are left free (and warned about).
    Off,
    /// When a direction is weak, with these tolerances.
    On {
        /// Lengths (metres).
        length: f64,
        /// Angles (radians).
        angle: f64,
    },
}

impl Default for PriorChoice {
    fn default() -> Self {
        PriorChoice::On {
            length: DEFAULT_LENGTH_TOLERANCE,
            angle: DEFAULT_ANGLE_TOLERANCE,
        }
    }
}

/// What the prior did, for the reports (JSON `prior`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PriorReport {
    /// The length tolerance (metres), `None` with the prior off.
    pub length_tolerance: Option<f64>,
    /// The angle tolerance (radians), `None` with the prior off.
    pub angle_tolerance: Option<f64>,
    /// Whether the prior was applied (some parameter was weak).
    pub applied: bool,
    /// The noise level `σ̂` (metres) the prior rows were scaled with, when applied.
    pub sigma: Option<f64>,
    /// The parameters whose standard deviation without the prior exceeded their tolerance
    /// (or that the data did not determine), spec order.
    pub weak: Vec<String>,
}

/// The tolerance of each of `model`'s parameters: `Some(τ)` for an estimated, free
/// parameter in a joint slot or the tool of `spec`, `None` otherwise.
pub(super) fn tolerances(
    model: &dyn CalibModel,
    spec: Option<&Spec>,
    choice: PriorChoice,
) -> Vec<Option<f64>> {
    let np = model.param_count();
    let (PriorChoice::On { length, angle }, Some(spec)) = (choice, spec) else {
        return vec![None; np];
    };
    let mut arm: Vec<&str> = spec
        .joints
        .iter()
        .flat_map(|j| [&j.home, &j.theta, &j.d, &j.offset, &j.a, &j.alpha])
        .chain(spec.tool.iter())
        .filter_map(|s| s.param())
        .collect();
    arm.sort_unstable();
    (0..np)
        .map(|j| {
            let name = model.param_name(j);
            let on_arm = arm.binary_search(&name).is_ok();
            (on_arm && !model.param_held(j)).then_some(if model.param_is_angle(j) {
                angle
            } else {
                length
            })
        })
        .collect()
}

/// The parameters (indices) whose standard deviation `std` exceeds their tolerance, or is
/// unknown.
pub(super) fn weak_params(tol: &[Option<f64>], std: &[Option<f64>]) -> Vec<usize> {
    tol.iter()
        .zip(std)
        .enumerate()
        .filter_map(|(j, (t, s))| {
            let t = (*t)?;
            s.is_none_or(|s| s.is_nan() || s > t).then_some(j)
        })
        .collect()
}

/// The noise level `sqrt(Σ‖g_l‖² / (m − n))` at `p`, `m` the residual components, `n` the
/// free parameters; at least 1 nm (exact data still get a prior that picks the nominal side
/// of a direction they leave undetermined).
pub(super) fn noise_level(model: &dyn CalibModel, poses: &Poses, p: &[f64], free: usize) -> f64 {
    let parts = crate::fit::geometric::fold_poses(
        model,
        poses,
        p,
        || (0.0, 0usize),
        |acc, l, _, d2| {
            acc.0 += d2;
            acc.1 += model
                .constraint_kind(poses.constraint.at(l))
                .residual_count(model.dim());
        },
    );
    let (cost, m) = parts
        .into_iter()
        .fold((0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1));
    let dof = m.saturating_sub(free).max(1) as f64;
    let s = (cost / dof).sqrt();
    if s.is_finite() {
        s.max(1e-9)
    } else {
        1e-9
    }
}

/// `model` with the prior rows `σ̂/τ_j` of [`tolerances`] `tol`.
pub(super) fn with_prior<'a>(
    model: &DataStart<'a>,
    tol: &[Option<f64>],
    sigma: f64,
) -> DataStart<'a> {
    model.with_prior(tol.iter().map(|t| t.map_or(0.0, |t| sigma / t)).collect())
}

/// The report of a fit that did not apply the prior (with `choice`'s tolerances).
pub fn not_applied(choice: PriorChoice) -> PriorReport {
    let (length_tolerance, angle_tolerance) = match choice {
        PriorChoice::On { length, angle } => (Some(length), Some(angle)),
        PriorChoice::Off => (None, None),
    };
    PriorReport {
        length_tolerance,
        angle_tolerance,
        applied: false,
        sigma: None,
        weak: Vec::new(),
    }
}

/// One sentence on what the prior did, for the text and HTML reports; `None` when it was
/// not applied.
#[must_use]
pub fn summary(report: &PriorReport) -> Option<String> {
    if !report.applied {
        return None;
    }
    Some(format!(
        "the data barely see {} (standard deviation above the tolerance), so the arm's \
         parameters were fitted with a prior around their nominals of {:.1e} m for lengths \
         and {:.1e} rad for angles, scaled by the noise level {:.3e} m; `--prior off` leaves \
         them free",
        report.weak.join(", "),
        report.length_tolerance.unwrap_or(f64::NAN),
        report.angle_tolerance.unwrap_or(f64::NAN),
        report.sigma.unwrap_or(f64::NAN)
    ))
}
