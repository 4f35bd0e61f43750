//! What the report shows beyond the [`CalibrateReport`](crate::report::CalibrateReport): the
//! nominals, the gauge, every pose's residual before and after, the measured tips' errors,
//! and every pose's leverage.
//!
//! Takes the model, spec, poses and estimate; gives [`ReportData`].

use crate::calibrate::estimate::Estimate;
use crate::calibrate::{pose_residuals, SpecParam};
use crate::data::Poses;
use crate::error::Result;
use crate::fit::start::DataStart;
use crate::model::CalibModel;
use crate::spec::Spec;
use crate::symbolic::SymbolicModel;

use super::leverage::{pose_leverage, Leverage};

/// The calibrated tip minus the measured tip of every pose on a `measured` constraint.
#[derive(Clone, Debug, PartialEq)]
pub struct TipErrors {
    /// 2 or 3 components a pose.
    pub dim: usize,
    /// The poses (0-based, of the data as given) with a measured tip.
    pub poses: Vec<usize>,
    /// Their error vectors, `dim` numbers a pose, metres.
    pub errors: Vec<f64>,
}

/// What the report shows beyond the [`CalibrateReport`](crate::report::CalibrateReport): the
/// nominals, the gauge, every pose's residual before and after, the measured tips' errors,
/// the worst poses' CSV lines.
#[derive(Clone, Debug, PartialEq)]
pub struct ReportData {
    /// Every parameter of the spec with its nominal value, spec order.
    pub nominal: Vec<(String, f64)>,
    /// The gauge directions, `{param: coefficient}` each (see
    /// [`SymbolicModel::gauge`]).
    pub gauge: Vec<Vec<(String, f64)>>,
    /// The constraint kinds, by name (`line`, `measured`, …).
    pub constraints: Vec<String>,
    /// Each pose's distance from its constraint with the nominal parameters, metres.
    pub before: Vec<f64>,
    /// Each pose's distance from its constraint with the calibrated parameters, metres.
    pub after: Vec<f64>,
    /// The error vectors of the measured tips, when the spec has a `measured` constraint.
    pub tip_errors: Option<TipErrors>,
    /// For measured poses (`measured_pose`): each pose's orientation error `‖log(R_mᵀR)‖`
    /// (radians) with the nominal and with the calibrated parameters.
    pub orientation: Option<(Vec<f64>, Vec<f64>)>,
    /// Each pose's leverage in the fit (`None` when it cannot be computed: no free
    /// parameter, no pose kept).
    pub leverage: Option<Leverage>,
    /// The CSV text of the worst poses' lines: `(line number, text)`; empty when the poses
    /// were not read from a file (see [`csv_lines`](super::csv_lines)).
    pub worst_lines: Vec<(usize, String)>,
    /// The accuracy map: the predicted tip uncertainty over the joints' ranges.
    pub accuracy: Option<super::accuracy::AccuracyMap>,
}

impl ReportData {
    /// Computes the residuals before (at the spec's nominals) and after (at `est`), and the
    /// measured tips' errors, for `poses` (the poses `est` was fitted to, as given: after
    /// `--reject-outliers` the dropped ones included). `worst_lines` is left empty.
    ///
    /// # Errors
    /// Poses that do not fit the model (a constraint index out of range).
    pub fn compute(
        model: &SymbolicModel,
        spec: &Spec,
        poses: &Poses,
        est: &Estimate,
    ) -> Result<ReportData> {
        let params = SpecParam::list(spec);
        let nominal_p: Vec<f64> = params
            .iter()
            .filter(|p| !p.known)
            .map(|p| p.nominal)
            .collect();
        let fitted_p: Vec<f64> = est
            .params
            .iter()
            .filter(|p| !p.known)
            .map(|p| p.value)
            .collect();
        let before = pose_residuals(model, poses, &nominal_p)?;
        let after = pose_residuals(model, poses, &fitted_p)?;
        let tip_errors = tip_errors(model, poses, &fitted_p);
        let orientation = est.orientation_rms.map(|_| {
            let norms = crate::calibrate::pose_errors::pose_error_norms;
            (
                norms(model, poses, &nominal_p).1,
                norms(model, poses, &fitted_p).1,
            )
        });
        Ok(ReportData {
            nominal: params.iter().map(|p| (p.name.clone(), p.nominal)).collect(),
            gauge: model.gauge(),
            constraints: spec
                .constraints
                .iter()
                .map(|c| c.kind_name().to_string())
                .collect(),
            before,
            after,
            tip_errors,
            orientation,
            leverage: leverage(model, poses, est, &fitted_p),
            worst_lines: Vec::new(),
            accuracy: super::accuracy::accuracy_map(model, poses, est, &fitted_p),
        })
    }
}

/// Each pose's leverage at the estimate, with the orientation weight the fit used (measured
/// poses) and the rejected poses left out; `None` when it cannot be computed.
fn leverage(model: &dyn CalibModel, poses: &Poses, est: &Estimate, p: &[f64]) -> Option<Leverage> {
    let left_out: Vec<usize> = est.rejected.iter().map(|w| w.pose).collect();
    let result = match &est.pose_noise {
        Some(noise) => {
            let weighted = DataStart::plain(model).with_orientation_weight(noise.weight);
            pose_leverage(&weighted, poses, p, &left_out)
        }
        None => pose_leverage(model, poses, p, &left_out),
    };
    result.ok()
}

/// Calibrated tip minus measured tip for every pose on a measured constraint; `None` when
/// there is none.
fn tip_errors(model: &dyn CalibModel, poses: &Poses, p: &[f64]) -> Option<TipErrors> {
    let measured = poses.measured.as_ref()?;
    let dim = model.dim();
    let mut out = TipErrors {
        dim,
        poses: Vec::new(),
        errors: Vec::new(),
    };
    let mut tip = vec![0.0; dim];
    for (l, q) in poses.q.iter().enumerate() {
        let on_measured = poses.constraint.get(l).is_some_and(|j| {
            j < model.constraint_count() && model.constraint_kind(j).is_measured()
        });
        let Some(m) = measured.get(l).filter(|m| m.len() >= dim) else {
            continue;
        };
        if !on_measured {
            continue;
        }
        model.tip(q, p, &mut tip);
        out.poses.push(l);
        out.errors.extend(tip.iter().zip(m).map(|(t, x)| t - x));
    }
    (!out.poses.is_empty()).then_some(out)
}
