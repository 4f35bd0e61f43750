//! Data simulation for any `CalibModel`: random joint readings projected onto the true
//! constraint by least-norm Newton steps in joint space, with optional noise.

use lincal_core::data::Poses;
use lincal_core::model::geometry::{geometric_residual, ConstraintKind};
use lincal_core::CalibModel;
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[derive(Clone, Copy, Debug)]
pub struct SimOptions {
    pub poses: usize,
    pub seed: u64,
    /// Std of the tip's geometric offset from the constraint (metres).
    pub track: f64,
    /// Std of the joint readings' noise (radians or metres).
    pub encoder: f64,
    /// Std of the measured tip's noise (metres).
    pub measure: f64,
}

impl SimOptions {
    pub fn new(poses: usize, seed: u64) -> Self {
        SimOptions {
            poses,
            seed,
            track: 0.0,
            encoder: 0.0,
            measure: 0.0,
        }
    }
}

pub fn gauss(rng: &mut impl Rng) -> f64 {
    loop {
        let u: f64 = rng.gen();
        if u > 1e-300 {
            let v: f64 = rng.gen();
            return (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos();
        }
    }
}

fn residual(model: &dyn CalibModel, j: usize, p: &[f64], q: &[f64], out: &mut [f64]) {
    let dim = model.dim();
    let kind = model.constraint_kind(j);
    let mut vals = vec![0.0; kind.value_count(dim)];
    model.constraint_values(j, p, &mut vals);
    let mut tip = vec![0.0; dim];
    model.tip(q, p, &mut tip);
    geometric_residual(kind, dim, &vals, &tip, &[], out);
}

/// Joint readings `q` with the tip at geometric offset `target` from constraint `j`.
fn project(
    model: &dyn CalibModel,
    j: usize,
    p: &[f64],
    q0: &[f64],
    target: &[f64],
) -> Option<Vec<f64>> {
    let n = model.joint_count();
    let m = target.len();
    let mut q = q0.to_vec();
    let mut r = vec![0.0; m];
    for _ in 0..80 {
        residual(model, j, p, &q, &mut r);
        for i in 0..m {
            r[i] -= target[i];
        }
        let norm = r.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !norm.is_finite() {
            return None;
        }
        if norm < 1e-15 {
            return Some(q);
        }
        let mut jac = DMatrix::zeros(m, n);
        let (mut rp, mut rm) = (vec![0.0; m], vec![0.0; m]);
        for c in 0..n {
            let h = 1e-7;
            let mut qq = q.clone();
            qq[c] += h;
            residual(model, j, p, &qq, &mut rp);
            qq[c] -= 2.0 * h;
            residual(model, j, p, &qq, &mut rm);
            for i in 0..m {
                jac[(i, c)] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        let jjt = &jac * jac.transpose();
        let step = jjt.lu().solve(&DVector::from_vec(r.clone()))?;
        let dq = jac.transpose() * step;
        let scale = dq.norm().max(1e-300);
        let damp = if scale > 0.5 { 0.5 / scale } else { 1.0 };
        for c in 0..n {
            q[c] -= damp * dq[c];
        }
    }
    residual(model, j, p, &q, &mut r);
    let norm: f64 = r
        .iter()
        .zip(target)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    (norm < 1e-13).then_some(q)
}

/// Joint readings near `q0` whose tip lies at the geometric offset `target` (one number per
/// residual component) from constraint `j` at parameters `p`; `None` when Newton fails.
pub fn place(
    model: &dyn CalibModel,
    j: usize,
    p: &[f64],
    q0: &[f64],
    target: &[f64],
) -> Option<Vec<f64>> {
    project(model, j, p, q0, target)
}

fn in_limits(model: &dyn CalibModel, q: &[f64]) -> bool {
    (0..q.len()).all(|i| match model.joint_limits(i) {
        Some([lo, hi]) => q[i] >= lo && q[i] <= hi,
        None => true,
    })
}

/// Simulates poses for the true parameters `p`. Poses cycle through the constraints.
pub fn simulate(model: &dyn CalibModel, p: &[f64], opts: SimOptions) -> Poses {
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let n = model.joint_count();
    let dim = model.dim();
    let m = model.constraint_count();
    let any_measured = (0..m).any(|j| model.constraint_kind(j) == ConstraintKind::Measured);
    let mut poses = Poses {
        measured: any_measured.then(|| lincal_core::data::Rows::new(dim)),
        ..Poses::default()
    };
    let range = |i: usize| -> [f64; 2] {
        model
            .joint_limits(i)
            .unwrap_or(if model.joint_is_prismatic(i) {
                [0.0, 0.3]
            } else {
                [-2.5, 2.5]
            })
    };
    let mut l = 0;
    let mut attempts = 0;
    while poses.len() < opts.poses {
        attempts += 1;
        assert!(
            attempts < 100 * opts.poses + 1000,
            "simulation cannot place poses"
        );
        let j = l % m;
        let kind = model.constraint_kind(j);
        let q0: Vec<f64> = (0..n)
            .map(|i| {
                let [lo, hi] = range(i);
                lo + (hi - lo) * rng.gen::<f64>()
            })
            .collect();
        let (q, measured) = if kind == ConstraintKind::Measured {
            let mut tip = vec![0.0; dim];
            model.tip(&q0, p, &mut tip);
            for t in &mut tip {
                *t += opts.measure * gauss(&mut rng);
            }
            (q0, tip)
        } else {
            let target: Vec<f64> = (0..kind.residual_count(dim))
                .map(|_| opts.track * gauss(&mut rng))
                .collect();
            let Some(q) = project(model, j, p, &q0, &target) else {
                continue;
            };
            if !in_limits(model, &q) {
                continue;
            }
            (q, Vec::new())
        };
        let q: Vec<f64> = q
            .iter()
            .map(|v| v + opts.encoder * gauss(&mut rng))
            .collect();
        poses.q.push(&q);
        if let Some(ms) = &mut poses.measured {
            ms.push(&measured);
        }
        poses.constraint.push(j);
        poses.line.push(l + 2);
        l += 1;
    }
    poses
}

/// Writes poses as CSV text (header `q1..qn[,x,y(,z)][,constraint]`).
pub fn to_csv(model: &dyn CalibModel, poses: &Poses, list: bool) -> String {
    let n = model.joint_count();
    let mut head: Vec<String> = (1..=n).map(|i| format!("q{i}")).collect();
    if poses.measured.is_some() {
        head.extend(["x", "y", "z"][..model.dim()].iter().map(|s| s.to_string()));
    }
    if list {
        head.push("constraint".into());
    }
    let mut s = head.join(",") + "\n";
    for l in 0..poses.len() {
        let mut cells: Vec<String> = poses.q[l].iter().map(|v| format!("{v:?}")).collect();
        if let Some(m) = &poses.measured {
            if m[l].is_empty() {
                cells.extend((0..model.dim()).map(|_| String::new()));
            } else {
                cells.extend(m[l].iter().map(|v| format!("{v:?}")));
            }
        }
        if list {
            cells.push(poses.constraint.at(l).to_string());
        }
        s += &(cells.join(",") + "\n");
    }
    s
}
