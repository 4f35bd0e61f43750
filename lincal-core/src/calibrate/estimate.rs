//! The result of a calibration: what `lincal calibrate` reports.

/// One calibrated parameter.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamEstimate {
    /// Name, as in the spec.
    pub name: String,
    /// Calibrated value (the nominal for known and held parameters).
    pub value: f64,
    /// Standard deviation; `None` for known and held parameters.
    pub std: Option<f64>,
    /// Identifiable on its own.
    pub identifiable: bool,
    /// Known (fixed at nominal by the spec).
    pub known: bool,
    /// Held at its nominal by the gauge rule.
    pub held: bool,
}

/// The iteratively reweighted robust fit (`--robust`), as reported: the linear solve is
/// reweighted on its algebraic residuals, and the parameter-space fit (refinement, or the fit
/// from the nominals or over every pose after a linear subset) on the geometric ones.
#[derive(Clone, Debug, PartialEq)]
pub struct RobustFit {
    /// The loss (`huber` or `cauchy`).
    pub loss: String,
    /// Its tuning constant, in robust standard deviations.
    pub tuning: f64,
    /// The robust scale σ̂ of the geometric residuals, metres per residual component: of the
    /// parameter-space fit's last round, or at the estimate when the linear estimate is
    /// reported alone.
    pub scale: f64,
    /// Rounds of reweighting of the parameter-space fit (0 when the linear estimate is
    /// reported alone, without refinement).
    pub rounds: usize,
    /// Poses with a weight below ½ in the last reweighting: of the parameter-space fit, or of
    /// the linear solve when the linear estimate is reported alone.
    pub downweighted: usize,
    /// Weighted linear solves run (0 when the linear method did not run, or when no
    /// constraint had a robust scale).
    pub linear_rounds: usize,
    /// Poses with a weight below ½ in the linear solve's last round.
    pub linear_downweighted: usize,
}

/// A pose far from its constraint (see [`Estimate::worst_poses`]).
#[derive(Clone, Debug, PartialEq)]
pub struct WorstPose {
    /// 0-based pose index.
    pub pose: usize,
    /// 1-based line of the pose in its file (0 when not read from a file).
    pub line: usize,
    /// Its data file, when the poses were joined from several ([`crate::data::PoseFiles`]).
    pub file: Option<String>,
    /// Geometric distance of the calibrated tip from its constraint (metres).
    pub residual: f64,
    /// The standardised residual `z = residual / (σ̂·χ̃_m)`: `σ̂` the robust scale
    /// ([`Estimate::robust_scale`]) and `χ̃_m` the median of a χ distribution with the pose's
    /// `m` residual components, so `z` is about 1 for a typical pose whatever its
    /// constraint's kind (one component or three). `None` when the robust scale is undefined
    /// (fewer than 10 poses, or exact data); for a rejected pose, at the fit that dropped it.
    pub standardized: Option<f64>,
    /// A measured pose's two parts, `(‖x − x_m‖` metres, `‖log(R_mᵀR)‖` radians`)`, of which
    /// `residual` is the weighted norm `√(position² + (w·orientation)²)`; `None` otherwise.
    pub pose_parts: Option<(f64, f64)>,
}

impl WorstPose {
    /// Where it was read, for messages: `line 8`, or `c1.csv line 8` from several files.
    #[must_use]
    pub fn place(&self) -> String {
        match &self.file {
            Some(f) => format!("{f} line {}", self.line),
            None => format!("line {}", self.line),
        }
    }
}

/// A whole calibration result.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// Every parameter of the spec, in spec order (known ones included).
    pub params: Vec<ParamEstimate>,
    /// Number of independent identifiable combinations.
    pub identifiable_count: usize,
    /// `K`, when known: the linear method built the basis, or it was small enough to build
    /// for the report after a fit from the nominals (see
    /// [`crate::model::CalibModel::basis_size_for_report`]); `None` for a basis beyond that.
    pub basis_size: Option<usize>,
    /// Poses used.
    pub poses: usize,
    /// Numerical rank of the data matrix (all groups stacked, per the solver's definition).
    pub rank: usize,
    /// RMS geometric distance of calibrated tips from the calibrated constraint (metres).
    pub residual_rms: f64,
    /// The paper's err_rms (sec. 5) for planar arms on a line, metres.
    pub paper_err_rms: Option<f64>,
    /// For measured poses (`measured_pose`): the RMS over poses of the orientation error
    /// `‖log(R_mᵀR)‖` (radians); `residual_rms` is then the position error's.
    pub orientation_rms: Option<f64>,
    /// For measured poses: the noise levels and the orientation weight the fit used, stated
    /// or estimated ([`crate::calibrate::pose_weight`]).
    pub pose_noise: Option<PoseNoise>,
    /// The covariance of the estimated (free) parameters, when the fit gave one: what
    /// `compensate` carries through the chain to a target's predicted uncertainty.
    pub covariance: Option<ParamCovarianceReport>,
    /// `"linear"` (the linear method alone) or `"linear+refine"` (Levenberg-Marquardt on the
    /// geometric residual, from the linear estimate or, where [`Self::start`] is `"nominal"`,
    /// from the nominals): the contract's two names (`shared/interface.md`).
    pub method: String,
    /// `"linear"` when the linear method gave the start, `"nominal"` otherwise.
    pub start: String,
    /// Poses the linear method used (0 when it did not run; fewer than `poses` when it ran
    /// on a subset).
    pub linear_poses: usize,
    /// Condition number of the column-equilibrated, gauge-fixed Jacobian at the estimate.
    pub condition: Option<f64>,
    /// The poses farthest from their constraint, in descending standardised residual
    /// ([`WorstPose::standardized`], so poses on constraints with different numbers of
    /// residual components compare fairly; in descending residual when it is undefined),
    /// pose indices of the data as given, also after `--reject-outliers`.
    pub worst_poses: Vec<WorstPose>,
    /// Robust scale of the residuals: the median of `‖g_l‖ / m_m` over the poses, `m_m` the
    /// median of a χ distribution with the pose's residual count `m` (so it estimates the
    /// noise σ per component whatever the mix of constraint kinds), metres.
    pub robust_scale: f64,
    /// Each joint's range of readings over the poses the fit used (the rejected left out):
    /// where the calibration interpolates ([`super::joint_ranges`]).
    pub joint_ranges: Vec<super::joint_ranges::JointRange>,
    /// Poses dropped by `--reject-outliers` (residual at the first fit), descending.
    pub rejected: Vec<WorstPose>,
    /// What the robust fit did (`--robust`), if one ran.
    pub robust: Option<RobustFit>,
    /// Human-readable warnings.
    pub warnings: Vec<String>,
    /// Generalized parameters found by the linear solve (equation-major, scaled so the
    /// constant function's coefficient is 1 where there is one); empty after a start from
    /// the nominals.
    pub generalized_params: Vec<f64>,
    /// For a constraint list: each constraint's residual (and a pinned point's spread) for
    /// the nominal and the calibrated model; empty for one constraint.
    pub constraints: Vec<crate::calibrate::constraint_fit::ConstraintFit>,
    /// Each relation's stated and achieved value, nominal and calibrated.
    pub relations: Vec<crate::calibrate::constraint_fit::RelationFit>,
    /// What the weak-direction prior did ([`crate::calibrate::prior`]).
    pub prior: crate::calibrate::prior::PriorReport,
    /// Each pair of pinned points of a list: the distance between the means of their
    /// predicted tips, nominal and calibrated (with the stated distance of a relation).
    pub point_distances: Vec<crate::calibrate::constraint_fit::PointDistance>,
    /// Held-out placements (`calibrate --validate`), each judged with the calibrated and the
    /// nominal parameters ([`crate::calibrate::validation::evaluate`]); empty unless asked.
    pub validation: Vec<crate::calibrate::validation::Evaluation>,
    /// k-fold cross-validation over the poses (`calibrate --folds K`), if asked.
    pub cross_validation: Option<crate::calibrate::validation::CrossValidation>,
    /// Each plane written by normal and offset (`n·x = d`), calibrated and unit-normalised
    /// ([`crate::calibrate::plane_fit`]); empty when the spec has none.
    pub planes: Vec<crate::calibrate::plane_fit::PlaneFit>,
}

/// The noise of a measured pose as the fit used it (JSON `pose_noise`; see
/// [`crate::calibrate::pose_weight`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PoseNoise {
    /// Standard deviation of one position coordinate (metres).
    pub position_std: f64,
    /// Standard deviation of one orientation component (radians).
    pub orientation_std: f64,
    /// `w = σ_p/σ_o`, the orientation residual's weight (metres per radian); when an
    /// estimated ratio fell outside [`crate::calibrate::pose_weight::WEIGHT_RANGE`], the bound
    /// it is held at (the ratio in `held_ratio`).
    pub weight: f64,
    /// The estimated `σ_p/σ_o` when `weight` is held at a bound of its range instead (one
    /// group fitted as if exact); `None` otherwise.
    pub held_ratio: Option<f64>,
    /// Which levels were estimated from the data (`"position"`, `"orientation"`), empty when
    /// the spec states both.
    pub estimated: Vec<String>,
    /// Variance-component rounds run (0 when the spec states both).
    pub rounds: usize,
}

/// The covariance of the estimated parameters (JSON `covariance`): `matrix[i][j]` is the
/// covariance of `params[i]` and `params[j]` (the free parameters, spec order; the known
/// ones and those the gauge rule holds have none), in their own units. With the prior
/// applied it is the posterior covariance `(JᵀJ/σ̂² + Σ⁻¹)⁻¹`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ParamCovarianceReport {
    /// The parameters, in the matrix's order.
    pub params: Vec<String>,
    /// The covariance, row by row.
    pub matrix: Vec<Vec<f64>>,
}

impl Estimate {
    /// The estimated parameters' values in the model's order (the spec's, known ones left
    /// out): what the model's functions take as `p`.
    #[must_use]
    pub fn estimated_values(&self) -> Vec<f64> {
        self.params
            .iter()
            .filter(|q| !q.known)
            .map(|q| q.value)
            .collect()
    }
}
