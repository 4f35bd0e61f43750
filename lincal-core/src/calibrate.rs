//! The calibration pipeline: linear solve → extraction → (optional) refinement → [`Estimate`].
//!
//! ```text
//! poses ──solve──▶ R_j (K×K per constraint), rank, linear c
//!       ──extract──▶ p̂ minimising Σ_j Σ_e ‖R_j c_e(p)‖² over the free set, σ̂²(JᵀJ)⁻¹
//!       ──refine──▶ p̂ minimising the geometric residual (with `refine: true`)
//! ```
//! `residual_rms` is `sqrt(Σ_l ‖g_l‖² / N)`, the RMS over poses of the geometric distance
//! `‖g_l‖` of the calibrated tip from the calibrated constraint (metres;
//! [`geometry::geometric_residual`]). For one planar line, `paper_err_rms` is the paper's
//! sec. 5 figure `sqrt(λ_min(I)/N)`, `I` the inertia matrix of the calibrated tips about
//! their centroid: the RMS distance of the tips from their own best-fit line.

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::estimate::{Estimate, ParamEstimate};
use crate::extract::{extract_from, Extraction};
use crate::geometry::{self, ConstraintKind};
use crate::model::CalibModel;
use crate::refine::refine;
use crate::solve::solve;
use crate::spec::Spec;

/// Options of [`calibrate`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CalibrateOptions {
    /// Refine the linear estimate by Levenberg-Marquardt on the geometric residual.
    pub refine: bool,
}

/// One parameter of the spec, as the report needs it.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecParam {
    /// Name.
    pub name: String,
    /// Nominal value.
    pub nominal: f64,
    /// Known (fixed at the nominal by the spec, not estimated).
    pub known: bool,
}

impl SpecParam {
    /// Every parameter of a spec, in spec order.
    #[must_use]
    pub fn list(spec: &Spec) -> Vec<SpecParam> {
        spec.params
            .iter()
            .map(|p| SpecParam {
                name: p.name.clone(),
                nominal: p.nominal.to_f64(),
                known: p.known,
            })
            .collect()
    }
}

/// [`calibrate`] with the parameter list taken from a spec.
///
/// # Example
/// A planar 2R arm with its tip on an unknown line: poses placed exactly on the line, then
/// the identifiable combinations come back (the gauge `a1, th1` is held at the nominals).
/// ```
/// use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
/// use lincal_core::data::Poses;
/// let yaml = "name: two_link
/// dim: 2
/// joints:
///   - {type: revolute, a: a1, home: th1}
///   - {type: revolute, a: a2, home: th2}
/// params: {a1: {nominal: 0.375}, th1: {nominal: 0}, a2: {nominal: 0.4},
///          th2: {nominal: 0}, b1: {nominal: -1.7}, b2: {nominal: -0.6}}
/// constraint: {line: {b: [b1, b2]}}
/// ";
/// let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
/// let model = lincal_core::symbolic::SymbolicModel::from_spec(&spec).unwrap();
/// // True arm a1 = 0.375, a2 = 0.425, th2 = 0.0446 on the line b = (-1.79, -0.56).
/// let (a1, a2, th2, b1, b2) = (0.375_f64, 0.425_f64, 0.0446_f64, -1.79_f64, -0.56_f64);
/// let mut poses = Poses::default();
/// for i in 0..40 {
///     let q2 = -2.0 + 0.1 * f64::from(i);
///     // tip = e^{i q1}·w, w = a1 + a2·e^{i(q2 − th2)}; solve b·tip + 1 = 0 for q1.
///     let (wx, wy) = (a1 + a2 * (q2 - th2).cos(), a2 * (q2 - th2).sin());
///     let c = -1.0 / (b1.hypot(b2) * wx.hypot(wy));
///     if c.abs() >= 1.0 {
///         continue; // this elbow angle cannot reach the line
///     }
///     let q1 = c.acos() - wy.atan2(wx) + b2.atan2(b1);
///     poses.q.push(vec![q1, q2]);
///     poses.constraint.push(0);
/// }
/// let est = calibrate_spec(&model, &spec, &poses, CalibrateOptions::default()).unwrap();
/// let value = |n: &str| est.params.iter().find(|p| p.name == n).unwrap().value;
/// assert!((value("a2") / value("a1") - a2 / a1).abs() < 1e-9);
/// assert!((value("th2") - th2).abs() < 1e-9);
/// assert!(est.residual_rms < 1e-9);
/// ```
///
/// # Errors
/// As [`calibrate`].
pub fn calibrate_spec(
    model: &dyn CalibModel,
    spec: &Spec,
    poses: &Poses,
    opts: CalibrateOptions,
) -> Result<Estimate> {
    calibrate_inner(model, &SpecParam::list(spec), poses, opts, Some(spec))
}

/// Calibrates `model` on `poses`.
///
/// `params` lists every parameter of the spec in spec order; the estimated ones (not
/// `known`) must be exactly the model's `p`, in order. The result has every spec parameter:
/// known ones at their nominal (`known: true`, `identifiable: false`, no std), held ones at
/// their nominal (`held: true`, no std), the rest fitted with their standard deviation.
///
/// # Errors
/// [`crate::error::ErrorClass::Degenerate`] when the poses cannot determine the parameters
/// (with the reason); [`crate::error::ErrorClass::Input`] for poses that do not fit the model;
/// [`crate::error::ErrorClass::Other`] for a model inconsistent with `params` or a numerical
/// failure. Never a NaN.
pub fn calibrate(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
) -> Result<Estimate> {
    calibrate_inner(model, params, poses, opts, None)
}

/// [`calibrate`], with the spec when there is one (for closed-form starts).
fn calibrate_inner(
    model: &dyn CalibModel,
    params: &[SpecParam],
    poses: &Poses,
    opts: CalibrateOptions,
    spec: Option<&Spec>,
) -> Result<Estimate> {
    let estimated: Vec<&SpecParam> = params.iter().filter(|p| !p.known).collect();
    let consistent = estimated.len() == model.param_count()
        && estimated
            .iter()
            .enumerate()
            .all(|(j, p)| p.name == model.param_name(j));
    if !consistent {
        return Err(Error::other(format!(
            "the model's parameters ({}) are not the spec's estimated parameters ({})",
            (0..model.param_count())
                .map(|j| model.param_name(j))
                .collect::<Vec<_>>()
                .join(", "),
            estimated
                .iter()
                .map(|p| p.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }

    let n = poses.len();
    let measured_ok = poses.measured.as_ref().is_none_or(|m| m.len() == n);
    if poses.constraint.len() != n || !measured_ok {
        return Err(Error::other(
            "inconsistent poses: every pose needs a constraint index (and a measured-tip entry when tips are measured)",
        ));
    }
    let lin = solve(model, poses)?;
    // The paper's sec. 4.1 closed form, where it applies, is the exact start of the general
    // extraction (which then only confirms it).
    let start = spec.and_then(|s| crate::closed_form::planar_line(s, model, &lin));
    let ext: Extraction = extract_from(model, &lin, start.as_deref())?;
    let mut warnings = ext.warnings.clone();
    let mut p = ext.p.clone();
    // The linear method's estimate minimises the algebraic cost Σ h², whose equations carry
    // different scales in a list or on a 3-D line: its covariance is the sandwich
    // H⁻¹MH⁻¹ (H = Σ aaᵀ, M = Σ_poses (Σ_e a r)(Σ_e a r)ᵀ), which needs no assumption about
    // those scales. (σ̂²(JᵀJ)⁻¹ is right only when every equation has the same scale.)
    let mut std = sandwich_std(model, poses, &ext.p, &ext.free).unwrap_or_else(|| ext.std.clone());
    let mut method = "linear";
    if opts.refine {
        match refine(model, poses, &ext.p) {
            Ok(r) if r.cost <= r.start_cost => {
                if r.p.iter().all(|v| v.is_finite())
                    && r.std.iter().flatten().all(|v| v.is_finite())
                {
                    p = r.p;
                    std = r.std;
                    method = "linear+refine";
                } else {
                    warnings.push(
                        "refinement produced a non-finite value and was rejected; the linear estimate is reported"
                            .to_string(),
                    );
                }
            }
            Ok(r) => warnings.push(format!(
                "refinement ended with a larger geometric cost ({:.3e}) than its start ({:.3e}) and was rejected; the linear estimate is reported",
                r.cost, r.start_cost
            )),
            Err(e) => warnings.push(format!(
                "refinement failed ({e}); the linear estimate is reported"
            )),
        }
    }
    // Wrap free angles (refinement may leave them outside (−π, π]).
    for &j in &ext.free {
        if model.param_is_angle(j) {
            p[j] = crate::extract::wrap_angle(p[j]);
        }
    }

    let stats = tip_statistics(model, poses, &p);
    let residual_rms = stats.residual_rms;
    let paper_err_rms = (model.dim() == 2
        && model.constraint_count() == 1
        && model.constraint_kind(0) == ConstraintKind::Line2)
        .then_some(stats.inertia_rms);

    let k = model.basis_size();
    if poses.len() < 2 * k {
        warnings.push(format!(
            "only {} poses for a basis of K = {k} functions: the fit has few redundant equations; use at least {}",
            poses.len(),
            2 * k
        ));
    }
    for g in lin.groups.iter().filter(|g| g.poses == 0) {
        warnings.push(format!(
            "constraint {} has no poses; its parameters stay at the values the other data allow",
            g.constraint
        ));
    }
    let frozen = lin.frozen_joints();
    if !frozen.is_empty() {
        let names: Vec<String> = frozen.iter().map(|i| format!("q{}", i + 1)).collect();
        warnings.push(format!("joints that never moved: {}", names.join(", ")));
    }
    // The data's scale: the spread of the tips, or a tenth of their distance from the base
    // origin when they cluster (a pinned point).
    let scale = stats.spread.max(0.1 * stats.reach);
    if scale > 0.0 && residual_rms > 0.05 * scale {
        let (l, d) = stats.worst;
        let line = poses
            .line
            .get(l)
            .map_or(String::new(), |n| format!(", line {n}"));
        warnings.push(format!(
            "the residual rms {residual_rms:.3e} m is {:.1}% of the scale of the data ({scale:.3e} m): the data is noisy or the model does not fit it; the farthest pose is {l}{line} ({d:.3e} m from the constraint)",
            100.0 * residual_rms / scale
        ));
    }
    // Readings outside the spec's joint limits are legal input but often a sign of a bad row.
    let mut outside = Vec::new();
    for (l, q) in poses.q.iter().enumerate() {
        for (i, &qi) in q.iter().enumerate() {
            if let Some([lo, hi]) = model.joint_limits(i) {
                if qi < lo || qi > hi {
                    let line = poses
                        .line
                        .get(l)
                        .map_or(String::new(), |n| format!(" (line {n})"));
                    outside.push(format!(
                        "pose {l}{line}: q{} = {qi} not in [{lo}, {hi}]",
                        i + 1
                    ));
                }
            }
        }
    }
    if !outside.is_empty() {
        const SHOWN: usize = 5;
        let more = outside.len().saturating_sub(SHOWN);
        warnings.push(format!(
            "{} joint reading(s) outside the spec's limits: {}{}",
            outside.len(),
            outside[..outside.len().min(SHOWN)].join("; "),
            if more > 0 {
                format!("; and {more} more")
            } else {
                String::new()
            }
        ));
    }

    let mut out_params = Vec::with_capacity(params.len());
    let mut j = 0;
    for sp in params {
        if sp.known {
            out_params.push(ParamEstimate {
                name: sp.name.clone(),
                value: sp.nominal,
                std: None,
                identifiable: false,
                known: true,
                held: false,
            });
        } else {
            let held = model.param_held(j);
            out_params.push(ParamEstimate {
                name: sp.name.clone(),
                value: p[j],
                std: if held { None } else { std[j] },
                identifiable: model.param_identifiable(j),
                known: false,
                held,
            });
            j += 1;
        }
    }
    let generalized_params = lin.generalized_params(model.equation_count());
    let finite = out_params
        .iter()
        .all(|q| q.value.is_finite() && q.std.is_none_or(f64::is_finite))
        && residual_rms.is_finite()
        && paper_err_rms.is_none_or(f64::is_finite)
        && generalized_params.iter().all(|v| v.is_finite());
    if !finite {
        return Err(Error::other(
            "the calibration produced a non-finite value; the data or the model is degenerate",
        ));
    }
    Ok(Estimate {
        params: out_params,
        identifiable_count: model.identifiable_count(),
        basis_size: k,
        poses: poses.len(),
        rank: lin.rank,
        residual_rms,
        paper_err_rms,
        method: method.to_string(),
        warnings,
        generalized_params,
    })
}

/// Heteroskedasticity-robust (sandwich) standard deviations of the algebraic least-squares
/// estimate at `p` over the free parameters `free`: with per-pose, per-equation residuals
/// `r_le = c_e(p)·Φ̃(q_l)` (minus the measured coordinate for measured tips) and rows
/// `a_le = Φ̃(q_l)ᵀ ∂c_e/∂p_free`, `Cov = H⁻¹ M H⁻¹`, `H = Σ a aᵀ`,
/// `M = Σ_l (Σ_e a_le r_le)(Σ_e a_le r_le)ᵀ` (clustered by pose), scaled by `N/(N − n)`.
/// `None` when `H` is singular or a value is not finite.
fn sandwich_std(
    model: &dyn CalibModel,
    poses: &Poses,
    p: &[f64],
    free: &[usize],
) -> Option<Vec<Option<f64>>> {
    use nalgebra::{DMatrix, DVector};
    let k = model.basis_size();
    let ne = model.equation_count();
    let np = model.param_count();
    let n = free.len();
    let mut std = vec![None; np];
    if n == 0 {
        return Some(std);
    }
    let mut c = vec![0.0; ne * k];
    model.generalized_params(p, &mut c);
    let mut jac = vec![0.0; ne * k * np];
    model.jacobian(p, &mut jac);
    let mut phi = vec![0.0; k];
    let mut h = DMatrix::<f64>::zeros(n, n);
    let mut meat = DMatrix::<f64>::zeros(n, n);
    for l in 0..poses.len() {
        model.basis(&poses.q[l], &mut phi);
        let j = poses.constraint[l];
        let mut score = DVector::<f64>::zeros(n);
        for e in (0..ne).filter(|&e| model.equation_constraint(e) == j) {
            let mut r: f64 = (0..k).map(|i| c[e * k + i] * phi[i]).sum();
            if model.constraint_kind(j) == ConstraintKind::Measured {
                // Equations of a measured constraint are the tip coordinates, in order.
                let coord = (0..e)
                    .filter(|&f| model.equation_constraint(f) == j)
                    .count();
                r -= poses.measured.as_ref()?.get(l)?.get(coord)?;
            }
            let a = DVector::<f64>::from_iterator(
                n,
                free.iter().map(|&fj| {
                    (0..k)
                        .map(|i| phi[i] * jac[(e * k + i) * np + fj])
                        .sum::<f64>()
                }),
            );
            h += &a * a.transpose();
            score += &a * r;
        }
        meat += &score * score.transpose();
    }
    let hinv = h.try_inverse()?;
    let dof = poses.len() as f64 / (poses.len().saturating_sub(n).max(1)) as f64;
    let cov = &hinv * meat * &hinv * dof;
    for (i, &fj) in free.iter().enumerate() {
        let v = cov[(i, i)].max(0.0).sqrt();
        if !v.is_finite() {
            return None;
        }
        std[fj] = Some(v);
    }
    Some(std)
}

/// Statistics of the calibrated tips.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TipStatistics {
    /// `sqrt(Σ_l ‖g_l‖² / N)`: RMS geometric distance from the constraint.
    pub residual_rms: f64,
    /// `sqrt(λ_min(I)/N)` of the tips' inertia (scatter) matrix about their centroid.
    pub inertia_rms: f64,
    /// `sqrt(Σ_l ‖x_l − x̄‖² / N)`: RMS distance of the tips from their centroid.
    pub spread: f64,
    /// `sqrt(Σ_l ‖x_l‖² / N)`: RMS distance of the tips from the base origin.
    pub reach: f64,
    /// The pose farthest from its constraint: `(pose index, distance ‖g_l‖)`.
    pub worst: (usize, f64),
}

/// Residual and spread of the tips at parameters `p` (two passes over the poses, three in
/// the plane).
#[must_use]
pub fn tip_statistics(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> TipStatistics {
    let dim = model.dim();
    let values: Vec<Vec<f64>> = (0..model.constraint_count())
        .map(|j| {
            let mut v = vec![0.0; model.constraint_kind(j).value_count(dim)];
            model.constraint_values(j, p, &mut v);
            v
        })
        .collect();
    let n = poses.len().max(1) as f64;
    let mut tip = vec![0.0; dim];
    let mut r = vec![0.0; dim.max(2)];
    let mut sum = 0.0;
    let mut worst = (0usize, 0.0f64);
    let mut reach = 0.0;
    let mut mean = vec![0.0; dim];
    for l in 0..poses.len() {
        let j = poses.constraint[l];
        let kind = model.constraint_kind(j);
        let nr = kind.residual_count(dim);
        model.tip(&poses.q[l], p, &mut tip);
        let measured = poses
            .measured
            .as_ref()
            .and_then(|m| m.get(l))
            .map_or(&[][..], Vec::as_slice);
        geometry::geometric_residual(kind, dim, &values[j], &tip, measured, &mut r[..nr]);
        let d2 = r[..nr].iter().map(|v| v * v).sum::<f64>();
        if d2 > worst.1 {
            worst = (l, d2);
        }
        sum += d2;
        for i in 0..dim {
            mean[i] += tip[i] / n;
            reach += tip[i] * tip[i];
        }
    }
    let mut scatter = vec![0.0; dim * dim];
    for l in 0..poses.len() {
        model.tip(&poses.q[l], p, &mut tip);
        for a in 0..dim {
            for b in 0..dim {
                scatter[a * dim + b] += (tip[a] - mean[a]) * (tip[b] - mean[b]);
            }
        }
    }
    let trace: f64 = (0..dim).map(|a| scatter[a * dim + a]).sum();
    let lmin = if dim == 2 {
        // The inertia matrix [[Σŷ², −Σx̂ŷ], [−Σx̂ŷ, Σx̂²]] has the scatter matrix's eigenvalues.
        // λ_min from the eigenvalue formula loses half the digits (√ε·spread after the square
        // root), so take the principal direction φ (accurate to ε) and sum the squared offsets
        // along its normal n in a third pass: λ_min = Σ (n·x̂_l)².
        let (a, b, c) = (scatter[0], scatter[1], scatter[3]);
        let phi = 0.5 * (2.0 * b).atan2(a - c);
        let (nx, ny) = (-phi.sin(), phi.cos());
        let mut s = 0.0;
        for q in &poses.q {
            model.tip(q, p, &mut tip);
            let d = nx * (tip[0] - mean[0]) + ny * (tip[1] - mean[1]);
            s += d * d;
        }
        s
    } else {
        let m = nalgebra::DMatrix::from_row_slice(dim, dim, &scatter);
        m.symmetric_eigenvalues().min().max(0.0)
    };
    TipStatistics {
        residual_rms: (sum / n).sqrt(),
        inertia_rms: (lmin / n).sqrt(),
        spread: (trace / n).sqrt(),
        reach: (reach / n).sqrt(),
        worst: (worst.0, worst.1.sqrt()),
    }
}
