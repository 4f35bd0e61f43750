//! Simulated calibration data: poses whose true tips lie on the true constraint, with the
//! noise of a real experiment (`lincal simulate`).
//!
//! # The method
//! 1. **True parameters** `p*`: from a truth file (a YAML mapping `name: value`, see
//!    [`truth_from_yaml_str`]) or the nominals perturbed deterministically with the seed
//!    ([`perturbed_truth`]): lengths by ±1–2 % (±1–2 mm when the nominal is 0), angles by up to
//!    ±0.02 rad, constraint coefficients by ±0.5–1 % so the constraint still crosses the
//!    workspace the nominal one crosses.
//! 2. **Joint readings**: uniform inside the joint limits (default `[−π, π]` for a revolute
//!    joint, `[0, 0.5]` m for a prismatic one), then projected onto the true constraint by
//!    Newton steps in joint space, the minimum-norm step `Δq = −J⁺ r = −Jᵀ(JJᵀ)⁻¹ r` (through
//!    the SVD) with `J = ∂r/∂q` by central differences. `r` is the geometric residual
//!    ([`geometry::geometric_residual`]: signed distance from a line or plane, offset from a
//!    point, `‖x − c‖ − r` for circles and spheres, Sampson distance for a quadric) minus a
//!    target offset. Its zero set is exactly that of [`geometry::constraint_function`], but it
//!    is in metres, so the tracking noise is a distance and the convergence test one number. A
//!    pose whose projection does not converge (to `1e-12` m), leaves the joint limits or
//!    reaches a singular configuration is rejected and a new one drawn.
//! 3. **Noise**: tracking noise (`--noise-track M`) sets the target offset to `N(0, M²)` per
//!    normal direction, so the true tip sits that far off the constraint (what a tracker that
//!    holds the tip on a laser line to within `M` does); encoder noise (`--noise-encoder RAD`)
//!    adds `N(0, RAD²)` to every recorded joint reading (metres for prismatic joints);
//!    measurement noise (`--noise-measure M`) adds `N(0, M²)` to every coordinate of a
//!    measured tip. For a `measured` constraint there is nothing to project onto: the readings
//!    stay uniform and the true tip is written as `x, y(, z)`.
//! 4. With a list of constraints, pose `l` lies on constraint `l mod count` (round robin).
//!
//! Everything is deterministic for a given seed (ChaCha8, with separate streams for the
//! truth and the poses, so `--truth` does not change the poses drawn).
//!
//! [`geometry::geometric_residual`]: crate::model::geometry::geometric_residual
//! [`geometry::constraint_function`]: crate::model::geometry::constraint_function

mod csv;
mod project;
mod speculate;
mod truth;

pub use csv::{write_csv, write_csv_header, write_csv_row};
pub(crate) use project::central_jacobian;
pub use project::default_joint_range;
pub use truth::{perturbed_truth, truth_from_yaml_file, truth_from_yaml_str, truth_to_yaml};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use self::project::Projector;
use self::speculate::Batch;
use self::truth::seeded_truth;
use crate::data::Poses;
use crate::error::{Error, Location, Result};
use crate::model::geometry::ConstraintKind;
use crate::model::CalibModel;
use crate::spec::Spec;

/// Noise levels of a simulated experiment (standard deviations; 0 for none).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Noise {
    /// Tracking noise: distance of the true tip from the constraint, metres, per normal
    /// direction.
    pub track: f64,
    /// Encoder noise added to the recorded joint readings (radians; metres for prismatic
    /// joints).
    pub encoder: f64,
    /// Noise added to each coordinate of a measured tip, metres.
    pub measure: f64,
    /// Noise of a measured orientation (`measured_pose`), radians per axis: the measured
    /// rotation is `R·exp([n]ₓ)`, `n ~ N(0, σ²I)` in the tool frame.
    pub orientation: f64,
}

impl Noise {
    /// Each level with the command-line option that sets it, in a fixed order.
    #[must_use]
    pub fn levels(self) -> [(&'static str, f64); 4] {
        [
            ("--noise-track", self.track),
            ("--noise-encoder", self.encoder),
            ("--noise-measure", self.measure),
            ("--noise-orientation", self.orientation),
        ]
    }
}

/// A simulated data set.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    /// The true estimated parameters `p*` (the model's order).
    pub truth: Vec<f64>,
    /// The recorded poses (joint readings with encoder noise, measured tips with measurement
    /// noise, the constraint of each pose).
    pub poses: Poses,
    /// The true joint readings, before encoder noise.
    pub true_q: Vec<Vec<f64>>,
}

/// One simulated pose, as [`simulate_each`] hands it over.
#[derive(Clone, Copy, Debug)]
pub struct SimPose<'a> {
    /// Pose index (0-based).
    pub index: usize,
    /// The recorded joint readings (encoder noise included).
    pub q: &'a [f64],
    /// The true joint readings.
    pub true_q: &'a [f64],
    /// The measured tip (measurement noise included), on a `measured` constraint.
    pub measured: Option<&'a [f64]>,
    /// The constraint the pose lies on.
    pub constraint: usize,
}

/// The largest `--noise-track` / `--noise-measure`, metres: beyond it nothing of the arm is
/// left in the data.
pub const MAX_NOISE_LENGTH: f64 = 1.0;
/// The largest `--noise-encoder`, radians (or metres on a prismatic joint).
pub const MAX_NOISE_ENCODER: f64 = 1.0;
/// Attempts on one constraint that may all fail before the simulation gives up on it.
pub const FAIL_FAST: usize = 500;
/// The most poses one simulation makes (bounded work: 10⁶ take about 2 s), on the command
/// line and in Python alike.
pub const MAX_POSES: usize = 10_000_000;
/// Longest stretch without a placed pose before the simulation gives up.
pub const STALL: std::time::Duration = std::time::Duration::from_secs(20);

/// Simulates `n` poses of `model` with true parameters `truth` (or the nominals perturbed
/// with `seed` when `None`), collected in memory; see [`simulate_each`].
///
/// # Errors
/// As [`simulate_each`].
pub fn simulate(
    model: &dyn CalibModel,
    spec: &Spec,
    n: usize,
    seed: u64,
    truth: Option<&[f64]>,
    noise: Noise,
) -> Result<Simulation> {
    let width = (0..model.constraint_count())
        .map(|j| model.constraint_kind(j))
        .filter(|k| k.is_measured())
        .map(|k| k.equation_count(model.dim()))
        .max();
    let mut poses = Poses {
        q: crate::data::Rows::new(model.joint_count()),
        measured: width.map(crate::data::Rows::new),
        ..Poses::default()
    };
    let mut true_q = Vec::with_capacity(n.min(1 << 16));
    let truth = simulate_each(model, spec, n, seed, truth, noise, |pose| {
        if let Some(m) = &mut poses.measured {
            m.push(pose.measured.unwrap_or(&[]));
        }
        poses.q.push(pose.q);
        poses.constraint.push(pose.constraint);
        poses.line.push(pose.index + 2);
        true_q.push(pose.true_q.to_vec());
        Ok(())
    })?;
    Ok(Simulation {
        truth,
        poses,
        true_q,
    })
}

/// The true parameters a simulation uses: `truth`, checked, or the seeded perturbation of
/// the nominals.
///
/// # Errors
/// A truth of the wrong length or with non-finite values.
pub fn resolve_truth(
    model: &dyn CalibModel,
    spec: &Spec,
    seed: u64,
    truth: Option<&[f64]>,
) -> Result<Vec<f64>> {
    let given = truth.is_some();
    let mut p: Vec<f64> = match truth {
        Some(t) => t.to_vec(),
        None => seeded_truth(model, spec, seed),
    };
    if p.len() != model.param_count() || p.iter().any(|v| !v.is_finite()) {
        return Err(Error::input(
            Location::default(),
            format!(
                "the true parameters must be {} finite numbers ({})",
                model.param_count(),
                (0..model.param_count())
                    .map(|j| model.param_name(j))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    if !model.relations().is_empty() {
        p = relation_truth(model, p, given)?;
    }
    Ok(p)
}

/// A truth that satisfies the spec's relations: a given one is checked (to 10⁻⁹ m), a drawn
/// one is moved onto them (the least change of the parameters they involve).
fn relation_truth(model: &dyn CalibModel, p: Vec<f64>, given: bool) -> Result<Vec<f64>> {
    if given {
        let unmet = crate::fit::relation::unmet(model, &p, 1e-9);
        if let Some(&(k, worst)) = unmet.first() {
            let rel = &model.relations()[k];
            return Err(Error::input(
                Location::default(),
                format!(
                    "the true parameters do not satisfy the spec's relations: `relations:` \
                     item {k} (from 0; {} between constraints {} and {}) is off by \
                     {worst:.3e} m{}: give values that do",
                    rel.kind.name(),
                    rel.between[0],
                    rel.between[1],
                    if unmet.len() > 1 {
                        format!(", and {} more", unmet.len() - 1)
                    } else {
                        String::new()
                    }
                ),
            ));
        }
        return Ok(p);
    }
    crate::fit::relation::project(model, &p).ok_or_else(|| {
        Error::degenerate(
            "the drawn true parameters cannot be moved onto the spec's relations: do two of \
             them contradict each other (two distances between the same constraints), or are \
             the related constraints' values all fixed?",
        )
    })
}

/// Checks the noise levels: finite, not negative, within [`MAX_NOISE_LENGTH`] and
/// [`MAX_NOISE_ENCODER`].
///
/// # Errors
/// [`ErrorClass::Input`] naming the option.
///
/// [`ErrorClass::Input`]: crate::error::ErrorClass::Input
pub fn check_noise(noise: Noise) -> Result<()> {
    let maxima = [
        MAX_NOISE_LENGTH,
        MAX_NOISE_ENCODER,
        MAX_NOISE_LENGTH,
        MAX_NOISE_ENCODER,
    ];
    for ((what, v), max) in noise.levels().into_iter().zip(maxima) {
        let place = Location {
            field: Some(what.to_string()),
            ..Location::default()
        };
        if v.is_finite() && v < 0.0 {
            return Err(Error::input(
                place,
                // `{:?}`: the shortest form that reads back (1e308, not 309 digits).
                format!("the noise level is negative ({v:?}): it is a standard deviation, >= 0"),
            ));
        }
        if !(v.is_finite() && v <= max) {
            return Err(Error::input(
                place,
                format!("the noise level must be a finite number from 0 to {max}, not {v:?}"),
            ));
        }
    }
    Ok(())
}

/// Simulates `n` poses and hands each to `emit` as soon as it is made (so memory does not
/// grow with `n`: the CLI writes rows as they come). Returns the true parameters.
///
/// Work is bounded: at most `200·n + 1000` attempts in all, a constraint none of whose first
/// [`FAIL_FAST`] attempts lands is given up at once, and so is a run that places nothing for
/// [`STALL`].
///
/// # Errors
/// [`ErrorClass::Input`] for a truth of the wrong length or non-finite values, or bad noise
/// ([`check_noise`]); [`ErrorClass::Degenerate`] when poses cannot be placed on the true
/// constraint (it does not cross the workspace inside the joint limits); any error of `emit`.
///
/// [`ErrorClass::Input`]: crate::error::ErrorClass::Input
/// [`ErrorClass::Degenerate`]: crate::error::ErrorClass::Degenerate
pub fn simulate_each(
    model: &dyn CalibModel,
    spec: &Spec,
    n: usize,
    seed: u64,
    truth: Option<&[f64]>,
    noise: Noise,
    mut emit: impl FnMut(&SimPose<'_>) -> Result<()>,
) -> Result<Vec<f64>> {
    let p = resolve_truth(model, spec, seed, truth)?;
    check_noise(noise)?;
    let count = model.constraint_count();
    let mut run = Run::new(model, &p, seed, n, noise);
    let mut recorded = vec![0.0; model.joint_count()];
    let mut tip = vec![0.0; 12];
    for l in 0..n {
        let j = l % count.max(1);
        let kind = model.constraint_kind(j);
        let q = run.place(l, j, kind)?;
        run.placed[j] += 1;
        run.record(&q, &mut recorded);
        let measured = run.measure(kind, &q, &mut tip);
        emit(&SimPose {
            index: l,
            q: &recorded,
            true_q: &q,
            measured,
            constraint: j,
        })?;
        // Time the consumer spent (a slow pipe) is not time spent failing to place poses.
        run.last_placed = std::time::Instant::now();
    }
    Ok(p)
}

/// The tracking-noise offset of an attempt on constraint `j`: one normal deviate per
/// residual component, drawn after the joint readings.
fn track_target(model: &dyn CalibModel, noise: Noise, rng: &mut ChaCha8Rng, j: usize) -> Vec<f64> {
    let m = model.constraint_kind(j).residual_count(model.dim());
    (0..m).map(|_| noise.track * normal(rng)).collect()
}

/// Whether attempts may be projected ahead: no noise is drawn between attempts (encoder,
/// measurement, orientation) and no constraint is measured (its poses are not projected).
fn speculative(model: &dyn CalibModel, noise: Noise) -> bool {
    noise.encoder == 0.0
        && noise.measure == 0.0
        && noise.orientation == 0.0
        && (0..model.constraint_count()).all(|j| !model.constraint_kind(j).is_measured())
}

/// A standard normal deviate (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.gen::<f64>(); // (0, 1]
    let u2: f64 = rng.gen::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// One run of [`simulate_each`]: the projector onto the true constraints, the poses' random
/// stream, and the counts that bound the work.
struct Run<'a> {
    model: &'a dyn CalibModel,
    p: &'a [f64],
    proj: Projector<'a>,
    rng: ChaCha8Rng,
    noise: Noise,
    n: usize,
    max_attempts: usize,
    attempts: usize,
    failed: Vec<usize>,
    placed: Vec<usize>,
    last_placed: std::time::Instant,
    /// Attempts projected ahead over threads, when nothing but the attempts reads the pose
    /// stream (see `speculate`); `None`: one attempt at a time.
    batch: Option<Batch>,
}

impl<'a> Run<'a> {
    /// A run of `n` poses with true parameters `p`, its pose stream seeded with `seed`.
    fn new(model: &'a dyn CalibModel, p: &'a [f64], seed: u64, n: usize, noise: Noise) -> Self {
        let count = model.constraint_count();
        let proj = Projector::new(model, p);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(2);
        Run {
            model,
            p,
            proj,
            rng,
            noise,
            n,
            max_attempts: n.max(1).saturating_mul(200).saturating_add(1000),
            attempts: 0,
            failed: vec![0usize; count],
            placed: vec![0usize; count],
            last_placed: std::time::Instant::now(),
            batch: speculative(model, noise).then(Batch::new),
        }
    }

    /// The true joint readings of pose `l` on constraint `j`: drawn (and, unless `j` is
    /// measured, projected at a tracking-noise offset) until one lands, or the error that
    /// ends the run when the work bound is reached.
    fn place(&mut self, l: usize, j: usize, kind: ConstraintKind) -> Result<Vec<f64>> {
        loop {
            self.attempts += 1;
            let hopeless = self.placed[j] == 0 && self.failed[j] >= FAIL_FAST;
            let stalled = self.attempts.is_multiple_of(64) && self.last_placed.elapsed() > STALL;
            if self.attempts > self.max_attempts || hopeless || stalled {
                return Err(self.give_up(l, j, hopeless, stalled));
            }
            if kind.is_measured() {
                return Ok(self.proj.draw(&mut self.rng));
            }
            let (model, noise) = (self.model, self.noise);
            let target = |rng: &mut ChaCha8Rng, j: usize| track_target(model, noise, rng, j);
            let landed = match &mut self.batch {
                Some(b) => {
                    let count = model.constraint_count();
                    b.next(&self.proj, &mut self.rng, (l, j, count), target)
                }
                None => {
                    let q0 = self.proj.draw(&mut self.rng);
                    let t = target(&mut self.rng, j);
                    self.proj.project(j, q0, &t)
                }
            };
            match landed {
                Some(q) => return Ok(q),
                None => self.failed[j] += 1,
            }
        }
    }

    /// The error of a run that could place only `l` poses: why it stopped and how many
    /// attempts failed on each constraint.
    fn give_up(&self, l: usize, j: usize, hopeless: bool, stalled: bool) -> Error {
        let model = self.model;
        let (n, max_attempts) = (self.n, self.max_attempts);
        let fails: Vec<String> = self
            .failed
            .iter()
            .enumerate()
            .filter(|(_, &f)| f > 0)
            .map(|(j, f)| {
                format!(
                    "constraint {j} ({}): {f} failed",
                    model.constraint_kind(j).name()
                )
            })
            .collect();
        let why = if hopeless {
            format!("the first {FAIL_FAST} attempts on constraint {j} all failed")
        } else if stalled {
            format!("no pose was placed for {} s", STALL.as_secs())
        } else {
            format!("after {max_attempts} attempts")
        };
        Error::degenerate(format!(
            "could place only {l} of {n} poses on the true constraint: {why} ({}): does the constraint cross the workspace inside the joint limits?",
            fails.join(", ")
        ))
    }

    /// The recorded joint readings of true readings `q`: with encoder noise when there is.
    fn record(&mut self, q: &[f64], recorded: &mut [f64]) {
        for (r, v) in recorded.iter_mut().zip(q) {
            *r = if self.noise.encoder > 0.0 {
                v + self.noise.encoder * normal(&mut self.rng)
            } else {
                *v
            };
        }
    }

    /// On a measured constraint, the true tip at `q` with measurement noise (written into
    /// `tip`; for a measured pose the tip and the rotation column-major, with orientation
    /// noise, 12 values); `None` on any other.
    fn measure<'t>(
        &mut self,
        kind: ConstraintKind,
        q: &[f64],
        tip: &'t mut [f64],
    ) -> Option<&'t [f64]> {
        let dim = self.model.dim();
        match kind {
            ConstraintKind::Measured => self.model.tip(q, self.p, &mut tip[..dim]),
            ConstraintKind::MeasuredPose => {
                let (mut x, mut rot) = ([0.0; 3], [0.0; 9]);
                self.model.tool_pose(q, self.p, &mut x, &mut rot);
                if self.noise.orientation > 0.0 {
                    let n: [f64; 3] =
                        std::array::from_fn(|_| self.noise.orientation * normal(&mut self.rng));
                    let e = crate::model::rotation::matrix_from_rotation_vector(n);
                    // R·E: column c of the product is R times column c of E.
                    let turned: [f64; 9] = std::array::from_fn(|k| {
                        let (c, i) = (k / 3, k % 3);
                        (0..3).map(|m| rot[3 * m + i] * e[3 * c + m]).sum()
                    });
                    rot = turned;
                }
                tip[..3].copy_from_slice(&x);
                tip[3..12].copy_from_slice(&rot);
            }
            _ => return None,
        }
        let width = kind.equation_count(dim);
        for t in tip[..dim].iter_mut() {
            if self.noise.measure > 0.0 {
                *t += self.noise.measure * normal(&mut self.rng);
            }
        }
        Some(&tip[..width])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::ErrorClass;
    use crate::symbolic::SymbolicModel;

    const TWO_LINK: &str = "
name: two_link
dim: 2
joints:
  - {type: revolute, a: a1, home: th1, limits: [-2.6, 2.6]}
  - {type: revolute, a: a2, home: th2, limits: [-2.5, 2.5]}
params:
  a1: {nominal: 0.375}
  a2: {nominal: 0.425}
  th1: {nominal: 0}
  th2: {nominal: 0}
  b1: {nominal: -1.79}
  b2: {nominal: -0.56}
constraint:
  line: {b: [b1, b2]}
";

    fn model() -> (Spec, SymbolicModel) {
        let spec = crate::spec::from_yaml_str(TWO_LINK, None).unwrap();
        let m = SymbolicModel::from_spec(&spec).unwrap();
        (spec, m)
    }

    #[test]
    fn poses_lie_on_the_true_line_inside_limits() {
        let (spec, m) = model();
        let sim = simulate(&m, &spec, 50, 7, None, Noise::default()).unwrap();
        assert_eq!(sim.poses.len(), 50);
        let p = &sim.truth;
        let mut tip = [0.0; 2];
        for q in &sim.poses.q {
            assert!(q[0].abs() <= 2.6 && q[1].abs() <= 2.5);
            m.tip(q, p, &mut tip);
            let h = p[4] * tip[0] + p[5] * tip[1] + 1.0;
            assert!(h.abs() < 1e-11, "h = {h}");
        }
    }

    #[test]
    fn attempts_projected_ahead_match_one_at_a_time() {
        let (spec, m) = model();
        let noise = Noise {
            track: 1e-5,
            ..Noise::default()
        };
        let p = resolve_truth(&m, &spec, 5, None).unwrap();
        let place_all = |ahead: bool| {
            let mut run = Run::new(&m, &p, 5, 300, noise);
            assert!(run.batch.is_some());
            if !ahead {
                run.batch = None;
            }
            let kind = m.constraint_kind(0);
            (0..300)
                .map(|l| {
                    let q = run.place(l, 0, kind).unwrap();
                    run.placed[0] += 1;
                    q
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(place_all(true), place_all(false));
    }

    #[test]
    fn deterministic_and_truth_independent_of_poses() {
        let (spec, m) = model();
        let a = simulate(
            &m,
            &spec,
            10,
            3,
            None,
            Noise {
                track: 1e-5,
                ..Noise::default()
            },
        )
        .unwrap();
        let b = simulate(
            &m,
            &spec,
            10,
            3,
            None,
            Noise {
                track: 1e-5,
                ..Noise::default()
            },
        )
        .unwrap();
        assert_eq!(a, b);
        let c = simulate(&m, &spec, 10, 4, None, Noise::default()).unwrap();
        assert_ne!(a.truth, c.truth);
    }

    #[test]
    fn tracking_noise_moves_tips_off_the_line() {
        let (spec, m) = model();
        let sim = simulate(
            &m,
            &spec,
            400,
            1,
            None,
            Noise {
                track: 1e-4,
                ..Noise::default()
            },
        )
        .unwrap();
        let p = &sim.truth;
        let nb = p[4].hypot(p[5]);
        let mut tip = [0.0; 2];
        let mut s2 = 0.0;
        for q in &sim.poses.q {
            m.tip(q, p, &mut tip);
            let d = (p[4] * tip[0] + p[5] * tip[1] + 1.0) / nb;
            s2 += d * d;
        }
        let rms = (s2 / 400.0).sqrt();
        assert!((rms - 1e-4).abs() < 2e-5, "rms {rms}");
    }

    #[test]
    fn truth_file_errors_are_located() {
        let (spec, m) = model();
        let e = truth_from_yaml_str("a1: 0.4\nzz: 1\n", Some("t.yaml"), &m, &spec).unwrap_err();
        let s = e.to_string();
        assert!(s.contains("t.yaml:2") && s.contains("zz"), "{s}");
        let e = truth_from_yaml_str("a1: [1\n", Some("t.yaml"), &m, &spec).unwrap_err();
        assert_eq!(e.class(), ErrorClass::Input);
        let p = truth_from_yaml_str("th2: pi/180\n", None, &m, &spec).unwrap();
        assert!((p[3] - std::f64::consts::PI / 180.0).abs() < 1e-15);
        // A spec-like document: its params' nominals are the truth.
        let text = TWO_LINK.replace("a2: {nominal: 0.425}", "a2: {nominal: 0.43}");
        let p = truth_from_yaml_str(&text, None, &m, &spec).unwrap();
        assert_eq!(p[1], 0.43);
        let p = truth_from_yaml_str("a2: {value: 0.44}\n", None, &m, &spec).unwrap();
        assert_eq!(p[1], 0.44);
        let e = truth_from_yaml_str("params:\n  a9: {nominal: 1}\n", Some("t.yaml"), &m, &spec)
            .unwrap_err();
        assert!(
            e.to_string().contains("t.yaml:2:3: field `params.a9`"),
            "{e}"
        );
    }

    #[test]
    fn unreachable_line_is_degenerate() {
        let (spec, m) = model();
        let truth = [0.375, 0.425, 0.0, 0.0, -0.1, -0.1];
        let e = simulate(&m, &spec, 5, 1, Some(&truth), Noise::default()).unwrap_err();
        assert_eq!(e.class(), ErrorClass::Degenerate);
    }
}
