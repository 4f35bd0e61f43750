//! The fit from the nominals with deterministic restarts about them, and the check that the
//! winner has not collapsed the arm (joints that no longer move the tip).
//!
//! Takes the model and the poses; gives the best [`GeometricEstimate`] and the starts tried.

use crate::data::Poses;
use crate::error::{Error, Result};
use crate::model::CalibModel;

use super::estimate::{converged, Converged, GeometricEstimate};

/// Deterministic restarts about the nominals tried by [`fit_from_nominal`] after the nominal
/// start itself.
pub const RESTARTS: usize = 6;

/// Restarts stop once this many of them have ended at the best cost found (no better one
/// since): far starts that all return to one minimum.
pub const CONFIRMATIONS: usize = 2;

/// Relative cost difference below which two fits ended at the same minimum.
const SAME_COST: f64 = 1e-6;

/// Restarts run only when one linearisation costs at most this many flops (`m·n²`, about
/// 2 ms): on larger data sets the nominal start alone is taken.
pub const RESTART_WORK: f64 = 1e6;

/// [`fit`](super::fit) from the nominals, then from [`RESTARTS`] deterministic perturbations
/// of them (free angles by up to ±0.5 rad, free lengths by up to ±20 % of the largest nominal
/// length); the lowest cost wins (only its covariance is computed). Returns the estimate and
/// how many starts were tried.
///
/// The starts are taken in order and the rule that stops them (two confirmations, an exact
/// fit) reads only the results before, so with two free cores ([`crate::cores`]) the fits
/// run two at a time, each core taking the next start as soon as its fit ends
/// (`two_at_once`): a fit the rule would not have run is abandoned unread, and the result
/// is the sequential one, bit for bit.
///
/// # Errors
/// As [`fit`](super::fit) for the nominal start.
pub fn fit_from_nominal(
    model: &dyn CalibModel,
    poses: &Poses,
) -> Result<(GeometricEstimate, usize)> {
    let np = model.param_count();
    let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
    let speeds = joint_speeds(model, poses, &nominal);
    // Restarts are for small data sets (where a start is cheap and a far local minimum is
    // likeliest); a large one has long since pulled the fit into the right basin.
    let work =
        super::problem::GeometricFit::new(model, poses, &nominal).map_or(f64::INFINITY, |g| {
            use crate::numeric::lm::LeastSquares;
            (g.components() + g.relation_components()) as f64 * (g.unknowns() as f64).powi(2)
        });
    let mut starts = vec![nominal.clone()];
    if work <= RESTART_WORK {
        starts.extend(restart_points(model, &nominal));
    }
    let search = Search {
        scale: length_scale(model),
        ..Search::default()
    };
    // Two at a time where a core is free; not while the basis built ahead holds it.
    let search = if starts.len() > 1 && crate::cores::free() > 1 {
        two_at_once(model, poses, &starts, &speeds, search)?
    } else {
        one_at_a_time(model, poses, &starts, &speeds, search)?
    };
    let Some(best) = search.best else {
        return Err(Error::other("no start was fitted (a bug)"));
    };
    if !search.collapsed.is_empty() {
        let names: Vec<String> = search
            .collapsed
            .iter()
            .map(|i| format!("q{}", i + 1))
            .collect();
        return Err(Error::degenerate(format!(
            "the fit from the nominals collapses the arm: joint(s) {} no longer move the tip, a degenerate mechanism that satisfies the constraint trivially; start it nearer the truth: enough poses for the linear start (at least K per constraint, `lincal basis` gives K), nominals of the fixture's values near where it stands (a plane's, a line's), or, when nothing fixes the arm's size (every length and the constraint's size free), a length held (`known: true`)",
            names.join(", ")
        )));
    }
    Ok((best.finish()?, search.tried))
}

/// The search over `starts` in order, one fit at a time.
fn one_at_a_time(
    model: &dyn CalibModel,
    poses: &Poses,
    starts: &[Vec<f64>],
    speeds: &[f64],
    mut search: Search,
) -> Result<Search> {
    for (k, start) in starts.iter().enumerate() {
        if search.done() {
            break;
        }
        search.take(
            model,
            poses,
            speeds,
            k,
            converged(model, poses, start, None),
        )?;
    }
    Ok(search)
}

/// The same search on two threads: each takes the next start as soon as its fit ends, and
/// whichever finishes a fit reads every result now complete in start order, as
/// [`one_at_a_time`] would. Once the search is done (or fails) the fit still running is
/// abandoned at its next iteration ([`crate::cancel::abandon_when`]): its result would not
/// be read. Fits end at different times (the nominal start in 4 iterations, a far one in
/// 6), so no core waits for the slower of a pair, as rounds of two made it.
fn two_at_once(
    model: &dyn CalibModel,
    poses: &Poses,
    starts: &[Vec<f64>],
    speeds: &[f64],
    search: Search,
) -> Result<Search> {
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    use std::sync::{Arc, Mutex, PoisonError};
    type Fitted = std::thread::Result<Result<Converged>>;
    struct Shared {
        results: Vec<Option<Fitted>>,
        read: usize,
        search: Search,
        failed: Option<Error>,
        /// A fit that panicked, resumed once it is the next result read (a fit the search
        /// would not have read may panic unseen, as it would not have run).
        panicked: Option<Box<dyn std::any::Any + Send>>,
    }
    if search.done() {
        return Ok(search);
    }
    let next = AtomicUsize::new(0);
    let stop = Arc::new(AtomicBool::new(false));
    let shared = Mutex::new(Shared {
        results: starts.iter().map(|_| None).collect(),
        read: 0,
        search,
        failed: None,
        panicked: None,
    });
    let work = || {
        let _abandon = crate::cancel::abandon_when(Arc::clone(&stop));
        while !stop.load(Ordering::SeqCst) {
            let k = next.fetch_add(1, Ordering::SeqCst);
            if k >= starts.len() {
                break;
            }
            let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                converged(model, poses, &starts[k], None)
            }));
            let mut sh = shared.lock().unwrap_or_else(PoisonError::into_inner);
            sh.results[k] = Some(result);
            while sh.failed.is_none() && sh.panicked.is_none() && !sh.search.done() {
                let at = sh.read;
                let Some(result) = sh.results.get_mut(at).and_then(Option::take) else {
                    break;
                };
                sh.read += 1;
                match result {
                    Ok(result) => {
                        if let Err(e) = sh.search.take(model, poses, speeds, at, result) {
                            sh.failed = Some(e);
                        }
                    }
                    Err(payload) => sh.panicked = Some(payload),
                }
            }
            let settled = sh.failed.is_some() || sh.panicked.is_some() || sh.search.done();
            if settled || sh.read == starts.len() {
                stop.store(true, Ordering::SeqCst);
            }
        }
    };
    crate::cores::join(work, work);
    let sh = shared.into_inner().unwrap_or_else(PoisonError::into_inner);
    if let Some(payload) = sh.panicked {
        std::panic::resume_unwind(payload);
    }
    match sh.failed {
        Some(e) => Err(e),
        None => Ok(sh.search),
    }
}

/// The [`RESTARTS`] deterministic starts about `nominal` (held parameters stay there).
fn restart_points(model: &dyn CalibModel, nominal: &[f64]) -> Vec<Vec<f64>> {
    use rand::{Rng, SeedableRng};
    let np = nominal.len();
    let scale = length_scale(model);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x1a2b);
    (0..RESTARTS)
        .map(|_| {
            (0..np)
                .map(|j| {
                    if model.param_held(j) {
                        nominal[j]
                    } else if model.param_is_angle(j) {
                        nominal[j] + 0.5 * rng.gen_range(-1.0..1.0)
                    } else {
                        nominal[j] + 0.2 * scale * rng.gen_range(-1.0..1.0)
                    }
                })
                .collect()
        })
        .collect()
}

/// The largest nominal length of the model, at least 0.1 (metres): the scale of the
/// restarts' length perturbations and of an exact fit's cost.
fn length_scale(model: &dyn CalibModel) -> f64 {
    (0..model.param_count())
        .filter(|&j| !model.param_is_angle(j))
        .fold(0.1f64, |m, j| m.max(model.param_nominal(j).abs()))
}

/// The state of [`fit_from_nominal`]'s search: the best fit so far, its collapsed joints,
/// how many later starts confirmed it, how many starts were taken, and the model's
/// [`length_scale`].
#[derive(Default)]
struct Search {
    best: Option<Converged>,
    collapsed: Vec<usize>,
    confirmed: usize,
    tried: usize,
    scale: f64,
}

impl Search {
    /// Whether no more starts are needed: far starts that all came back to the best minimum
    /// (a landscape with one basin about the nominals, where more would only repeat it), or
    /// an exact fit (the cost per component tiny against the data's scale).
    fn done(&self) -> bool {
        let Some(best) = &self.best else {
            return false;
        };
        if !self.collapsed.is_empty() {
            return false;
        }
        let rms = (best.cost / best.components.max(1) as f64).sqrt();
        self.confirmed >= CONFIRMATIONS || rms <= 1e-9 * self.scale
    }

    /// Takes start `k`'s fit: the nominal start's error is the search's; a restart's failure
    /// is only a start that did not help.
    fn take(
        &mut self,
        model: &dyn CalibModel,
        poses: &Poses,
        speeds: &[f64],
        k: usize,
        result: Result<Converged>,
    ) -> Result<()> {
        self.tried += 1;
        let e = match result {
            Ok(e) => e,
            Err(err) if k == 0 => return Err(err),
            Err(_) => return Ok(()),
        };
        let c = collapsed_from(model, poses, speeds, &e.p);
        let Some(best) = &self.best else {
            self.best = Some(e);
            self.collapsed = c;
            return Ok(());
        };
        // A mechanism that stopped moving is no answer, however well it fits.
        let better = if c.is_empty() == self.collapsed.is_empty() {
            e.cost < best.cost * (1.0 - 1e-9)
        } else {
            c.is_empty()
        };
        let same = !better && c.is_empty() && e.cost <= best.cost * (1.0 + SAME_COST);
        if better {
            self.best = Some(e);
            self.collapsed = c;
            self.confirmed = 0;
        } else if same {
            self.confirmed += 1;
        }
        Ok(())
    }
}

/// Joints that move the tip at the nominals but (almost) not at `p`: the RMS over the poses
/// of `‖∂x/∂q_i‖` (exact along the model's chain, central differences without one; this is a
/// check, not a fit) falls below `10⁻⁶` of its nominal value.
#[must_use]
pub fn collapsed_joints(
    model: &dyn CalibModel,
    poses: &Poses,
    nominal: &[f64],
    p: &[f64],
) -> Vec<usize> {
    collapsed_from(model, poses, &joint_speeds(model, poses, nominal), p)
}

/// [`collapsed_joints`] with the nominal speeds ([`joint_speeds`]) computed once.
fn collapsed_from(model: &dyn CalibModel, poses: &Poses, nominal: &[f64], p: &[f64]) -> Vec<usize> {
    let now = joint_speeds(model, poses, p);
    (0..nominal.len())
        .filter(|&i| nominal[i] > 0.0 && now[i] < 1e-6 * nominal[i])
        .collect()
}

/// Per joint, how fast the tip moves with it at `params`: the root of the sum over (at most
/// 64 of) the poses of `‖∂x/∂q_i‖²`, exact along the model's chain (one pass per pose,
/// [`crate::model::chain::tip_joint_jacobian`]; `2J` tips per pose before), else by central
/// differences ([`differenced_speeds`]) for a model without one.
fn joint_speeds(model: &dyn CalibModel, poses: &Poses, params: &[f64]) -> Vec<f64> {
    let dim = model.dim();
    let step = poses.len().div_ceil(64).max(1);
    let nj = model.joint_count();
    let factors = model.chain();
    let chained = !factors.is_empty() && factors.iter().all(|f| f.joint.is_none_or(|k| k < nj));
    if !chained || dim > 3 {
        return differenced_speeds(model, poses, params);
    }
    let (mut tip, mut jac) = ([0.0; 3], vec![0.0; dim * nj]);
    let mut twists = vec![[0.0; 6]; nj];
    let mut sums = vec![0.0; nj];
    for q in poses.q.iter().step_by(step) {
        crate::model::chain::tip_joint_jacobian(
            factors,
            dim,
            q,
            params,
            &mut tip[..dim],
            &mut jac,
            &mut twists,
        );
        for (k, sum) in sums.iter_mut().enumerate() {
            *sum += (0..dim).map(|i| jac[i * nj + k].powi(2)).sum::<f64>();
        }
    }
    sums.into_iter().map(f64::sqrt).collect()
}

/// [`joint_speeds`] from the model's tips alone: `‖x(q + h·e_i) − x(q − h·e_i)‖ / 2h` in
/// place of `‖∂x/∂q_i‖`, `h = 10⁻⁴`.
fn differenced_speeds(model: &dyn CalibModel, poses: &Poses, params: &[f64]) -> Vec<f64> {
    let dim = model.dim();
    let step = poses.len().div_ceil(64).max(1);
    (0..model.joint_count())
        .map(|i| {
            let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
            let mut sum = 0.0;
            for q in poses.q.iter().step_by(step) {
                let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
                qp[i] += 1e-4;
                qm[i] -= 1e-4;
                model.tip(&qp, params, &mut a[..dim]);
                model.tip(&qm, params, &mut b[..dim]);
                sum += (0..dim).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>();
            }
            sum.sqrt() / 2e-4
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symbolic::{testutil::repo_spec, SymbolicModel};

    /// The search on two threads gives the sequential one's result bit for bit and tries as
    /// many starts: noisy data (restarts until two confirm), exact data (the nominal fit
    /// ends the search at once, the other thread's fit abandoned) and starts far off, on
    /// planar and spatial arms.
    #[test]
    fn two_at_once_is_the_sequential_search() {
        use crate::simulate::{simulate, Noise};
        let mut tried = Vec::new();
        for (name, noise, shift) in [
            ("lincal-models/specs/planar3_line.yaml", 1e-4, 0.0),
            ("lincal-models/specs/planar3_line.yaml", 0.0, 0.0),
            ("lincal-models/specs/planar3_line.yaml", 1e-4, 1.5),
            ("lincal-models/specs/planar3_line.yaml", 1e-4, 2.5),
            ("lincal-models/specs/planar3_line.yaml", 1e-4, 3.0),
            ("lincal-models/specs/scara_plane.yaml", 1e-4, 2.0),
            ("lincal-models/specs/planar3_point.yaml", 1e-4, 2.8),
            ("lincal-models/specs/puma560_plane.yaml", 5e-5, 0.0),
            ("bench/specs/panda_point.yaml", 5e-5, 0.3),
        ] {
            let spec = repo_spec(name);
            let model =
                SymbolicModel::for_fitting(&spec, crate::symbolic::DEFAULT_MAX_TERMS).unwrap();
            let noise = Noise {
                track: noise,
                encoder: noise,
                measure: 0.0,
                orientation: 0.0,
            };
            let sim = simulate(&model, &spec, 40, 7, None, noise).unwrap();
            let np = model.param_count();
            let nominal: Vec<f64> = (0..np).map(|j| model.param_nominal(j)).collect();
            let mut starts = vec![nominal.clone()];
            starts.extend(restart_points(&model, &nominal));
            // A shifted nominal start; beyond 2.6 rad its lengths are scaled too, a start
            // in another basin.
            for (j, x) in starts[0].iter_mut().enumerate() {
                if model.param_held(j) {
                    continue;
                }
                if model.param_is_angle(j) {
                    *x += shift;
                } else if shift > 2.6 {
                    *x *= 3.0;
                }
            }
            let speeds = joint_speeds(&model, &sim.poses, &nominal);
            let search = || Search {
                scale: length_scale(&model),
                ..Search::default()
            };
            let a = one_at_a_time(&model, &sim.poses, &starts, &speeds, search()).unwrap();
            let b = two_at_once(&model, &sim.poses, &starts, &speeds, search()).unwrap();
            let (ea, eb) = (a.best.unwrap(), b.best.unwrap());
            tried.push(a.tried);
            assert_eq!(a.tried, b.tried, "{name}: starts tried");
            assert_eq!(ea.cost.to_bits(), eb.cost.to_bits(), "{name}: cost");
            assert!(
                ea.p.iter()
                    .zip(&eb.p)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "{name}: estimate"
            );
            assert_eq!(a.collapsed, b.collapsed, "{name}: collapsed joints");
        }
        // The cases cover an exact fit that ends the search, two confirmations, and a start
        // that a later one improves on.
        assert!(tried.contains(&1) && tried.contains(&3), "{tried:?}");
        assert!(tried.iter().any(|&t| t > 3), "{tried:?}");
    }

    /// The speeds along the chain equal the differenced ones to the differences' accuracy,
    /// revolute and prismatic joints, planar and spatial, off the nominals.
    #[test]
    fn chain_speeds_equal_differenced_ones() {
        for name in [
            "tests/specs/prismatic_scara.yaml",
            "tests/specs/urdf_native_sphere.yaml",
            "lincal-models/specs/puma560_plane.yaml",
            "tests/specs/point_planar3.yaml",
        ] {
            let spec = repo_spec(name);
            let model = SymbolicModel::from_spec(&spec).unwrap();
            let p: Vec<f64> = (0..model.param_count())
                .map(|j| model.param_nominal(j) + 0.01 * ((j * 7 % 5) as f64 - 2.0))
                .collect();
            let nj = model.joint_count();
            let readings: Vec<f64> = (0..20 * nj)
                .map(|k| ((k * 3 + k / nj * 5) % 11) as f64 * 0.13 - 0.6)
                .collect();
            let poses = Poses {
                q: crate::data::Rows::from_vec(nj, readings).unwrap(),
                ..Poses::default()
            };
            assert!(!model.chain().is_empty(), "{name}");
            let (a, b) = (
                joint_speeds(&model, &poses, &p),
                differenced_speeds(&model, &poses, &p),
            );
            for (i, (x, y)) in a.iter().zip(&b).enumerate() {
                assert!(
                    (x - y).abs() <= 1e-6 * y.max(1e-3),
                    "{name} joint {i}: {x} vs {y}"
                );
                assert!(*x > 0.0, "{name} joint {i} does not move the tip");
            }
        }
    }
}
