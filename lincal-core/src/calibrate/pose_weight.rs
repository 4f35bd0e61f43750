//! Full-pose measurements (`measured_pose`): the weight of the orientation residual against
//! the position residual, stated by the spec or estimated from the data, and the position
//! and orientation errors the reports give.
//!
//! The fit minimises `Σ_l ‖x_l − x_{m,l}‖² + w²·‖φ_l‖²`, `φ_l = log(R_{m,l}ᵀR_l)`, with
//! `w = σ_p/σ_o` (metres per radian), `σ_p` and `σ_o` the noise of one position coordinate
//! and of one orientation component. When the spec states both, `w` is their ratio. When it
//! leaves one or both out, they are estimated by variance components (Förstner's iteration):
//! fit with the current `w`, then, with `J` the weighted Jacobian at the estimate split into
//! its position rows `J_p` and orientation rows `J_o`, `N = JᵀJ` and the redundancies
//! `r_p = 3N − tr(N⁻¹J_pᵀJ_p)`, `r_o = 3N − tr(N⁻¹J_oᵀJ_o)` (they sum to the degrees of
//! freedom `6N − n`),
//!
//! `σ̂_p² = Σ‖x − x_m‖²/r_p`,  `σ̂_o² = Σ‖φ‖²/r_o`,  `w ← σ̂_p/σ̂_o`,
//!
//! until `w` moves by less than [`WEIGHT_TOL`] (a stated level is kept as stated). Each
//! round is a whole fit; a few rounds suffice, as `w` enters the estimate only through the
//! balance of two well-determined groups.

use nalgebra::DMatrix;

use super::fit_stage::fit_stage;
use super::CalibrateOptions;
use crate::data::Poses;
use crate::error::Result;
use crate::fit::geometric::pose_jacobians;
use crate::fit::start::DataStart;
use crate::model::CalibModel;
use crate::spec::Spec;

pub use super::estimate::PoseNoise;

/// Relative change of `w` below which the variance-component rounds stop.
pub const WEIGHT_TOL: f64 = 1e-3;

/// Most variance-component rounds (each a whole fit).
pub const WEIGHT_ROUNDS: usize = 8;

/// The range an estimated orientation weight is held to (metres per radian). Real sensors
/// give `σ_p/σ_o` between about 10⁻² and 10² m/rad (a laser tracker's 6-DoF probe: 20 µm and
/// 0.1 mrad, 0.2 m/rad). A ratio far outside says one group is exact, not measured (simulated
/// orientations without noise, rounded to 16 digits): weighing it by that ratio would drown
/// the other group, and with it every direction only the other group sees. The bounds keep
/// both groups within 10⁴ of an arm-sized balance; a stated ratio is used as stated.
pub const WEIGHT_RANGE: (f64, f64) = (1e-4, 1e4);

/// The orientation weight for `model` on `poses`: the spec's stated ratio, or the
/// variance-component estimate (see the module docs) held within [`WEIGHT_RANGE`], with a
/// warning when it had to be held.
///
/// # Errors
/// As the fits of the rounds.
pub(super) fn pose_noise(
    model: &dyn CalibModel,
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
) -> Result<(PoseNoise, Option<String>)> {
    let (sp, so) = spec.and_then(Spec::pose_noise).unwrap_or((None, None));
    if let (Some(sp), Some(so)) = (sp, so) {
        let noise = PoseNoise {
            position_std: sp,
            orientation_std: so,
            weight: sp / so,
            held_ratio: None,
            estimated: Vec::new(),
            rounds: 0,
        };
        return Ok((noise, None));
    }
    let start = match (sp, so) {
        (Some(_), Some(_)) | (None, None) => model.orientation_weight(),
        // One level stated: start from a ratio as if the other were of a typical size.
        (Some(sp), None) => sp / 5e-5,
        (None, Some(so)) => 2e-5 / so,
    };
    let mut w = start.clamp(WEIGHT_RANGE.0, WEIGHT_RANGE.1);
    // The rounds need no prior nor robust loss: they only balance the two groups.
    let round_opts = CalibrateOptions {
        refine: true,
        robust: None,
        reject_outliers: false,
        prior: super::prior::PriorChoice::Off,
        ..opts
    };
    let mut noise = (f64::NAN, f64::NAN);
    let mut rounds = 0;
    let mut held = None;
    while rounds < WEIGHT_ROUNDS {
        rounds += 1;
        let weighted = DataStart::new(model, poses).with_orientation_weight(w);
        let fit = fit_stage(&weighted, poses, round_opts, spec, None)?;
        let Some((vp, vo)) = variance_components(&weighted, poses, &fit.p, w) else {
            break;
        };
        let (sp_hat, so_hat) = (sp.unwrap_or(vp.sqrt()), so.unwrap_or(vo.sqrt()));
        noise = (sp_hat, so_hat);
        let ratio = sp_hat / so_hat;
        if !(ratio.is_finite() && ratio > 0.0) {
            break;
        }
        let next = ratio.clamp(WEIGHT_RANGE.0, WEIGHT_RANGE.1);
        held = (next != ratio).then_some(ratio);
        let moved = (next / w - 1.0).abs();
        w = next;
        if moved < WEIGHT_TOL {
            break;
        }
    }
    let warning = held.map(|ratio| held_warning(ratio, noise, (sp.is_none(), so.is_none()), w));
    let mut estimated = Vec::new();
    if sp.is_none() {
        estimated.push("position".to_string());
    }
    if so.is_none() {
        estimated.push("orientation".to_string());
    }
    let noise = PoseNoise {
        position_std: noise.0,
        orientation_std: noise.1,
        weight: w,
        held_ratio: held,
        estimated,
        rounds,
    };
    Ok((noise, warning))
}

/// A stated level this far from the residuals' own (either way) is named in a warning.
pub const STATED_MISMATCH: f64 = 1.5;

/// When the spec states both noise levels: a warning naming each level the residuals at the
/// estimate `p` put more than [`STATED_MISMATCH`]× away from the stated one (variance
/// components with the stated weight, as in the module docs). The fit weighs the groups by
/// the stated ratio and its standard deviations (and `compensate`'s σ) take that balance as
/// true, so a spec that misstates its instrument reports an accuracy it does not have.
pub(super) fn stated_mismatch(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    noise: &PoseNoise,
) -> Option<String> {
    if !noise.estimated.is_empty() {
        return None;
    }
    let (vp, vo) = variance_components(model, poses, p, noise.weight)?;
    let off = |seen: f64, stated: f64| {
        let r = seen / stated;
        (!(1.0 / STATED_MISMATCH..=STATED_MISMATCH).contains(&r)).then_some(r)
    };
    let (sp, so) = (vp.sqrt(), vo.sqrt());
    let mut parts = Vec::new();
    if let Some(r) = off(sp, noise.position_std) {
        parts.push(format!(
            "position {sp:.3e} m against the stated {:.3e} m ({r:.2}×)",
            noise.position_std
        ));
    }
    if let Some(r) = off(so, noise.orientation_std) {
        parts.push(format!(
            "orientation {so:.3e} rad against the stated {:.3e} rad ({r:.2}×)",
            noise.orientation_std
        ));
    }
    (!parts.is_empty()).then(|| {
        format!(
            "the residuals put the measurement noise at {}: the fit weighs orientation against \
             position by the ratio of the levels `measured_pose` states, and the standard \
             deviations it reports (and `compensate`'s sigma) take that balance as true; state \
             the instrument's levels, or leave them out to have them estimated",
            parts.join(", ")
        )
    })
}

/// Why the weight `w` is not the ratio `ratio` of the levels `noise` (`estimated`: whether
/// each came from the data, else the spec).
fn held_warning(ratio: f64, noise: (f64, f64), estimated: (bool, bool), w: f64) -> String {
    let (exact, other) = if ratio > 1.0 {
        ("orientations", "positions")
    } else {
        ("positions", "orientations")
    };
    let how = |e: bool| if e { "estimated" } else { "stated" };
    format!(
        "the measured {exact} fit far better than the {other} ({} position std {:.3e} m, {} \
         orientation std {:.3e} rad: a ratio of {ratio:.3e} m/rad), as if they were exact \
         rather than measured; the orientation weight is held at {w:.0e} m/rad so that the \
         {other} still count (state `measured_pose: {{position_std: M, orientation_std: RAD}}` \
         in the spec to weigh them yourself)",
        how(estimated.0),
        noise.0,
        how(estimated.1),
        noise.1
    )
}

/// `(σ̂_p², σ̂_o²)` at `p` with weight `w` (see the module docs); `None` when the
/// redundancies leave nothing to estimate from (too few poses) or a level is zero (exact
/// data: no noise to balance).
fn variance_components(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    w: f64,
) -> Option<(f64, f64)> {
    let jac = pose_jacobians(model, poses, p).ok()?;
    let n = jac.free.len();
    let width = jac.width();
    let (mut gp, mut go) = (DMatrix::<f64>::zeros(n, n), DMatrix::<f64>::zeros(n, n));
    let (mut ssp, mut sso, mut rows) = (0.0, 0.0, 0usize);
    for l in 0..poses.len() {
        let block = jac.pose(l);
        if block.len() != 6 * width {
            continue; // not a measured pose
        }
        rows += 3;
        for (c, row) in block.chunks_exact(width).enumerate() {
            let (g, ss) = if c < 3 {
                (&mut gp, &mut ssp)
            } else {
                (&mut go, &mut sso)
            };
            let j = nalgebra::DVector::from_column_slice(&row[..n]);
            g.ger(1.0, &j, &j, 1.0);
            *ss += row[n] * row[n];
        }
    }
    let normal = &gp + &go;
    let inv = normal.clone().cholesky()?.inverse();
    let tp = (&inv * &gp).trace();
    let to = (&inv * &go).trace();
    let (rp, ro) = (rows as f64 - tp, rows as f64 - to);
    if !(rp > 1.0 && ro > 1.0 && ssp > 0.0 && sso > 0.0) {
        return None;
    }
    // The orientation rows carry w·φ: their sum of squares over w² is Σ‖φ‖².
    Some((ssp / rp, sso / (w * w) / ro))
}
