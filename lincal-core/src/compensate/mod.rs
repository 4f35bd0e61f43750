//! Applying a calibration on a robot whose controller keeps its nominal model: for each
//! target, the joints `q′` that put the *calibrated* model's tool on it (`lincal compensate`).
//!
//! A target is either
//! - a joint target `q₀` (a joint program, or joints the controller's nominal model solved):
//!   the intended tool is the **nominal** model's, `x* = FK_nominal(q₀)` (its pose when the
//!   spec's tool is a frame, `measured_pose`), and `q₀` is the seed. With
//!   [`Compensator::place_by_calibrated_base`] the nominal arm stands where the calibration
//!   found it instead: a `base:` parameter (a laser tracker's registration, not an error of
//!   the arm) takes its calibrated value, so a tracker standing metres away does not read as a
//!   metres-large error; or
//! - a Cartesian target `x*` (`x, y, z`, with an orientation for a pose) in the measurement
//!   (world) frame of the spec, with its seed joints `q₀`.
//!
//! Each is solved for `FK_calibrated(q′) = x*` by damped Gauss-Newton from the seed on the
//! exact joint Jacobian, each step the least-norm one from the seed ([`solve`]), so a redundant
//! task keeps the seed's self-motion and branch. Each result carries:
//! - the filtered target `FK_nominal(q′)`: for a controller that takes Cartesian targets and
//!   solves them with its nominal model (RoboDK's `FilterTarget` rule,
//!   `FK_nominal(IK_calibrated(x*))`);
//! - the correction `‖q′ − q₀‖` (radians, metres for prismatic joints);
//! - the residual `‖x* − x(q′)‖`, metres;
//! - `σ`, the calibration's predicted tool position uncertainty at `q′` ([`sigma`]);
//! - a [`Status`]: `ok`, or why `q′` must not be used ([`verdict`]).
//!
//! Many targets are solved on every core, in input order ([`Compensator::compensate_all`]).
//! The parts: [`task`] (errors and Jacobians), [`solve`], [`verdict`], [`sigma`], [`targets`]
//! (reading a targets file), [`summary`] (counts and worst rows).

pub mod sigma;
pub mod solve;
pub mod summary;
pub mod targets;
pub mod task;
pub mod verdict;

pub use sigma::ParamCovariance;
pub use solve::{Solution, SolveOptions};
pub use summary::Summary;
pub use targets::{TargetForm, Targets};
pub use task::{Goal, TargetKind, Tool};
pub use verdict::{Status, Verdict};

use crate::error::{Error, Result};
use crate::model::chain::{self, Factor, Motion};
use crate::spec::chain::Chain;
use crate::spec::Spec;
use task::Arm;

/// [`Compensator`]'s prepared motions: the nominal parameters'.
const NOMINAL: usize = 0;
/// The joint targets [`Compensator::base_shift`] reads at most.
pub const BASE_SHIFT_SAMPLE: usize = 200;
/// The [`Compensator::base_shift`] beyond which [`Compensator::base_shift_warning`] speaks
/// (metres): a robot's mounting in its cell errs by millimetres, a tracker's registration
/// guessed from a drawing by centimetres to metres.
pub const BASE_SHIFT_WARN: f64 = 0.01;
/// The intended tool's parameters'.
const INTENDED: usize = 1;
/// The calibrated parameters'.
const CALIBRATED: usize = 2;

/// A spec's chain with its nominal and calibrated parameters, ready to compensate targets.
#[derive(Clone, Debug)]
pub struct Compensator {
    factors: Vec<Factor>,
    dim: usize,
    joints: usize,
    /// The parameters whose tool is a joint target's intended tool: the nominals (the
    /// interface's rule), or with [`Compensator::place_by_calibrated_base`] the nominals with
    /// the calibrated values of the `base:` parameters.
    intended: Vec<f64>,
    /// The `base:` parameters' positions in the estimated parameters.
    base_params: Vec<usize>,
    calibrated: Vec<f64>,
    limits: Vec<Option<[f64; 2]>>,
    pose: bool,
    covariance: ParamCovariance,
    /// The chain's [`chain::prepare`]d motions at the nominal, intended and calibrated
    /// parameters: a solve then takes a sine and cosine per joint only, not per factor.
    motions: [Vec<Motion>; 3],
    /// The solve's limits.
    pub options: SolveOptions,
}

/// The result for one target.
#[derive(Clone, Debug, PartialEq)]
pub struct Outcome {
    /// The compensated joints `q′` (for a failed target, the solve's last point: not to be
    /// sent to a robot).
    pub q: Vec<f64>,
    /// The filtered target `FK_nominal(q′)`.
    pub filtered: Tool,
    /// `‖q′ − q₀‖`.
    pub correction: f64,
    /// `‖x* − FK_calibrated(q′)‖` (position), metres.
    pub residual: f64,
    /// The orientation's remaining error of a pose target, radians (0 otherwise).
    pub orientation_residual: f64,
    /// `√tr` of the predicted tool position covariance at `q′`, metres.
    pub sigma: f64,
    /// The status and its reason.
    pub verdict: Verdict,
    /// Iterations of the solve.
    pub iterations: usize,
}

impl Compensator {
    /// The compensator of `spec` with the calibrated values `calibrated` of its estimated
    /// parameters (spec order) and their covariance.
    ///
    /// # Errors
    /// An input error when `calibrated` (or the covariance) has another length than the
    /// spec's estimated parameters, or a value is not finite.
    pub fn new(spec: &Spec, calibrated: Vec<f64>, covariance: ParamCovariance) -> Result<Self> {
        let est = spec.estimated_params();
        let np = est.len();
        let cov_len = match &covariance {
            ParamCovariance::None => None,
            ParamCovariance::Diagonal(v) => Some((v.len(), np)),
            ParamCovariance::Full(v) => Some((v.len(), np * np)),
        };
        if calibrated.len() != np || cov_len.is_some_and(|(a, b)| a != b) {
            return Err(Error::other(format!(
                "the calibrated parameters ({}) do not match the spec's {np} estimated ones",
                calibrated.len()
            )));
        }
        if calibrated.iter().any(|v| !v.is_finite()) {
            return Err(Error::other("a calibrated parameter is not finite"));
        }
        let nominal: Vec<f64> = est.iter().map(|p| p.nominal.to_f64()).collect();
        let base_names = spec.base_params();
        let base_params = (0..est.len())
            .filter(|&j| base_names.contains(&est[j].name.as_str()))
            .collect();
        let factors = Chain::from_spec(spec).factors;
        let prepared = |p: &[f64]| {
            let mut m = vec![Motion::default(); factors.len()];
            chain::prepare(&factors, p, &mut m);
            m
        };
        let motions = [
            prepared(&nominal),
            prepared(&nominal),
            prepared(&calibrated),
        ];
        Ok(Compensator {
            motions,
            factors,
            dim: spec.dim,
            joints: spec.joints.len(),
            intended: nominal,
            base_params,
            calibrated,
            limits: spec.joints.iter().map(|j| j.limits).collect(),
            pose: spec.is_measured_pose() && spec.dim == 3,
            covariance,
            options: SolveOptions::default(),
        })
    }

    /// A joint target's intended tool placed where the calibration found the arm: the
    /// nominal arm with the calibrated values of the spec's `base:` parameters. For a `base:`
    /// that is a laser tracker's frame (its registration, not an error of the arm) the
    /// nominal `base:` puts the nominal tool in another frame than the calibrated model's, so
    /// every joint target reads as off by the tracker's distance (`lincal compensate
    /// --intended-base calibrated`). Without unknown `base:` parameters it changes nothing.
    #[must_use]
    pub fn place_by_calibrated_base(mut self) -> Self {
        for &j in &self.base_params {
            self.intended[j] = self.calibrated[j];
        }
        chain::prepare(&self.factors, &self.intended, &mut self.motions[INTENDED]);
        self
    }

    /// How far the calibrated `base:` moves the nominal arm's tool at the joint targets
    /// `seeds` (the median over at most [`BASE_SHIFT_SAMPLE`] of them, metres):
    /// `‖FK_nominal,placed(q) − FK_nominal(q)‖`, the nominal arm placed by the calibrated
    /// `base:` against the nominal model. Under the default rule every joint target's
    /// correction carries it, which is right where `base:` is an error of the arm's
    /// mounting and wrong where it is a measuring device's registration (a laser tracker's,
    /// [`Self::place_by_calibrated_base`]). `None` without unknown `base:` parameters, once
    /// placed, or without seeds.
    #[must_use]
    pub fn base_shift<'q>(&self, seeds: impl Iterator<Item = &'q [f64]>) -> Option<f64> {
        let placed_already = self
            .base_params
            .iter()
            .all(|&j| self.intended[j] == self.calibrated[j]);
        if self.base_params.is_empty() || placed_already {
            return None;
        }
        let mut placed = self.intended.clone();
        for &j in &self.base_params {
            placed[j] = self.calibrated[j];
        }
        let mut motions = vec![Motion::default(); self.factors.len()];
        chain::prepare(&self.factors, &placed, &mut motions);
        let arm = Arm {
            motions: &motions,
            ..self.arm(INTENDED)
        };
        let mut shifts: Vec<f64> = seeds
            .take(BASE_SHIFT_SAMPLE)
            .map(|q| {
                let (a, b) = (arm.tool(q).x, self.intended_tool(q).x);
                (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
            })
            .collect();
        shifts.sort_by(f64::total_cmp);
        shifts.get(shifts.len() / 2).copied()
    }

    /// A warning when `targets` are joint targets whose intended tool the calibrated `base:`
    /// moves by more than [`BASE_SHIFT_WARN`] ([`Self::base_shift`]): under the default rule
    /// the corrections then carry the distance between the nominal and the calibrated
    /// `base:`, every row `ok` where the nominal `base:` is a rough guess of a tracker's
    /// pose, and `diverged` where it is metres off.
    #[must_use]
    pub fn base_shift_warning(&self, targets: &Targets) -> Option<String> {
        if targets.form != TargetForm::Joints {
            return None;
        }
        let shift = self.base_shift(targets.poses.q.iter())?;
        (shift > BASE_SHIFT_WARN).then(|| {
            format!(
                "the calibrated `base:` moves the nominal arm's tool by {shift:.3e} m (median \
                 over the joint targets), and by default a joint target's intended tool is the \
                 nominal model's in the nominal `base:` frame, so the corrections carry that \
                 distance; where `base:` is a measuring device's frame (a laser tracker's \
                 registration) and not an error of the arm's mounting, add `--intended-base \
                 calibrated` (Python `intended_base=\"calibrated\"`)"
            )
        })
    }

    /// The joint count.
    #[must_use]
    pub fn joints(&self) -> usize {
        self.joints
    }

    /// 2 (planar) or 3.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Whether the tool is a frame (joint targets are poses, outputs carry an orientation).
    #[must_use]
    pub fn is_pose(&self) -> bool {
        self.pose
    }

    /// The arm at the nominal, intended or calibrated parameters (`which`: [`NOMINAL`],
    /// [`INTENDED`], [`CALIBRATED`]).
    fn arm(&self, which: usize) -> Arm<'_> {
        Arm {
            factors: &self.factors,
            motions: &self.motions[which],
            dim: self.dim,
            joints: self.joints,
        }
    }

    /// The nominal model's tool frame at `q`, in the controller's frame (the nominal
    /// `base:`): the filtered target.
    #[must_use]
    pub fn nominal_tool(&self, q: &[f64]) -> Tool {
        self.arm(NOMINAL).tool(q)
    }

    /// The intended tool of a joint target `q`: [`Self::nominal_tool`], or with
    /// [`Self::place_by_calibrated_base`] the nominal arm's tool placed by the calibrated
    /// `base:` (the frame the calibrated model and the Cartesian targets live in).
    #[must_use]
    pub fn intended_tool(&self, q: &[f64]) -> Tool {
        self.arm(INTENDED).tool(q)
    }

    /// The calibrated model's tool frame at `q`.
    #[must_use]
    pub fn calibrated_tool(&self, q: &[f64]) -> Tool {
        self.arm(CALIBRATED).tool(q)
    }

    /// Compensates one target: the seed `seed` and the Cartesian goal `goal` with its
    /// kind, or `None` for a joint target (goal [`Self::intended_tool`] at the seed, a pose when
    /// [`Self::is_pose`]).
    #[must_use]
    pub fn compensate(&self, seed: &[f64], goal: Option<(Goal, TargetKind)>) -> Outcome {
        let mut w = Workspace::new(self);
        self.compensate_with(seed, goal, &mut w)
    }

    fn compensate_with(
        &self,
        seed: &[f64],
        goal: Option<(Goal, TargetKind)>,
        w: &mut Workspace,
    ) -> Outcome {
        let (goal, kind) = goal.unwrap_or_else(|| {
            let t = self.intended_tool(seed);
            let kind = if self.pose {
                TargetKind::Pose
            } else {
                TargetKind::Position
            };
            let rot = self.pose.then_some(t.rot);
            (Goal { x: t.x, rot }, kind)
        });
        let cal = self.arm(CALIBRATED);
        let sol = solve::solve(&cal, &goal, kind, seed, &self.options, &mut w.solve);
        let m = cal.rows(kind);
        let n = self.joints;
        let mut e = [0.0; 6];
        cal.error(
            seed,
            &goal,
            kind,
            &mut e[..m],
            Some(&mut w.jac_seed[..m * n]),
            &mut w.scratch,
        );
        cal.error(
            &sol.q,
            &goal,
            kind,
            &mut e[..m],
            Some(&mut w.jac_end[..m * n]),
            &mut w.scratch,
        );
        let verdict = verdict::judge(
            &sol,
            &verdict::Evidence {
                seed,
                jac_seed: &w.jac_seed[..m * n],
                jac_end: &w.jac_end[..m * n],
                rows: m,
                limits: &self.limits,
            },
            &self.options,
        );
        Outcome {
            filtered: self.nominal_tool(&sol.q),
            correction: verdict::distance(&sol.q, seed),
            residual: sol.position_error,
            orientation_residual: sol.orientation_error,
            sigma: w
                .sigma
                .at(&self.factors, &sol.q, &self.calibrated, &self.covariance),
            verdict,
            iterations: sol.iterations,
            q: sol.q,
        }
    }

    /// Compensates every target of `targets`, in their order, over the machine's cores.
    #[must_use]
    pub fn compensate_all(&self, targets: &Targets) -> Vec<Outcome> {
        let work = |r: std::ops::Range<usize>| {
            let mut w = Workspace::new(self);
            r.map(|l| self.compensate_with(&targets.poses.q[l], targets.goal(l), &mut w))
                .collect::<Vec<_>>()
        };
        // A target's solve costs a few dozen poses' passes: both cores from 64 targets on.
        crate::fit::geometric::map_ranges(targets.len(), crate::cores::available(), 64, work)
            .into_iter()
            .flatten()
            .collect()
    }
}

/// The buffers of one thread's solves.
struct Workspace {
    solve: solve::Work,
    scratch: task::Scratch,
    jac_seed: Vec<f64>,
    jac_end: Vec<f64>,
    sigma: sigma::Sigma,
}

impl Workspace {
    fn new(c: &Compensator) -> Self {
        Workspace {
            solve: solve::Work::new(c.joints),
            scratch: task::Scratch::new(c.joints),
            jac_seed: vec![0.0; 6 * c.joints],
            jac_end: vec![0.0; 6 * c.joints],
            sigma: sigma::Sigma::new(c.dim, c.calibrated.len()),
        }
    }
}

#[cfg(test)]
mod tests;
