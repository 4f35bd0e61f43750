//! The default prior (issue 47): its information is fixed, so the estimate converges to the
//! plain least-squares fit as poses are added; its strength is chosen by grouped
//! cross-validation, stronger where the data carry an error the model cannot hold; and the
//! estimate is a continuous function of the strength (no per-parameter switch).

use lincal_core::calibrate::prior::{PriorChoice, PriorScale, PriorShape};
use lincal_core::calibrate::{calibrate_spec, CalibrateOptions};
use lincal_core::data::{Poses, Rows};
use lincal_core::symbolic::SymbolicModel;
use lincal_core::CalibModel;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::sim::gauss;

/// A spatial 4R arm (DH), every a, α, d, home unknown and a measured tip: a tracker on a
/// small arm. `constraints` measured placements (tracker sessions), one when 1.
fn spec(constraints: usize) -> String {
    let mut s = String::from(
        "name: arm4
dim: 3
joints:
  - {type: revolute, a: a1, alpha: al1, d: d1, home: th1}
  - {type: revolute, a: a2, alpha: al2, d: d2, home: th2}
  - {type: revolute, a: a3, alpha: al3, d: d3, home: th3}
  - {type: revolute, a: a4, alpha: al4, d: d4, home: th4}
tool: [0.05, 0.02, 0.1]
params:
  a1: {nominal: 0.05}
  al1: {nominal: -1.5707963267948966}
  d1: {nominal: 0.3}
  th1: {nominal: 0.0}
  a2: {nominal: 0.4}
  al2: {nominal: 0.0}
  d2: {nominal: 0.02}
  th2: {nominal: 0.0}
  a3: {nominal: 0.03}
  al3: {nominal: -1.5707963267948966}
  d3: {nominal: 0.0}
  th3: {nominal: 0.0}
  a4: {nominal: 0.0}
  al4: {nominal: 1.5707963267948966}
  d4: {nominal: 0.35}
  th4: {nominal: 0.0}
",
    );
    if constraints == 1 {
        s.push_str("constraint:\n  measured: {}\n");
    } else {
        s.push_str("constraints:\n");
        for _ in 0..constraints {
            s.push_str("  - measured: {}\n");
        }
    }
    s
}

fn model(yaml: &str) -> (lincal_core::spec::Spec, SymbolicModel) {
    let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
    let m = SymbolicModel::from_spec(&spec).unwrap();
    (spec, m)
}

/// The truth: every free parameter off the drawing by up to 2 mm or 4 mrad, a fixed pattern.
fn truth(m: &SymbolicModel) -> Vec<f64> {
    (0..m.param_count())
        .map(|j| {
            let nom = m.param_nominal(j);
            if m.param_held(j) {
                return nom;
            }
            let s = ((j * 7919 % 13) as f64 / 12.0) * 2.0 - 1.0;
            nom + s * if m.param_is_angle(j) { 4e-3 } else { 2e-3 }
        })
        .collect()
}

/// `n` measured tips at random readings, `noise` metres per coordinate, cycling through the
/// model's constraints (placements). The arm's joints 2 and 3 sag under gravity by
/// `sag·cos` of their link's elevation: an error no DH parameter holds.
fn tracker_data(m: &SymbolicModel, p: &[f64], n: usize, noise: f64, sag: f64, seed: u64) -> Poses {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let placements = m.constraint_count();
    let mut poses = Poses {
        measured: Some(Rows::new(3)),
        ..Poses::default()
    };
    for l in 0..n {
        let j = l % placements;
        // Each placement works in its own region of joint space, as a session does.
        let centre = -1.5 + 3.0 * (j as f64 + 0.5) / placements as f64;
        let q: Vec<f64> = (0..4)
            .map(|i| {
                let spread = if placements > 1 && i == 0 { 0.4 } else { 2.5 };
                let c = if placements > 1 && i == 0 {
                    centre
                } else {
                    0.0
                };
                c + spread * (2.0 * rng.gen::<f64>() - 1.0)
            })
            .collect();
        let mut bent = q.clone();
        bent[1] += sag * q[1].cos();
        bent[2] += sag * (q[1] + q[2]).cos();
        let mut tip = [0.0; 3];
        m.tip(&bent, p, &mut tip);
        let tip: Vec<f64> = tip.iter().map(|t| t + noise * gauss(&mut rng)).collect();
        poses.q.push(&q);
        if let Some(ms) = &mut poses.measured {
            ms.push(&tip);
        }
        poses.constraint.push(j);
        poses.line.push(l + 2);
    }
    poses
}

fn fit(
    spec: &lincal_core::spec::Spec,
    m: &SymbolicModel,
    poses: &Poses,
    prior: PriorChoice,
) -> lincal_core::calibrate::estimate::Estimate {
    calibrate_spec(
        m,
        spec,
        poses,
        CalibrateOptions {
            prior,
            refine: true,
            ..Default::default()
        },
    )
    .unwrap()
}

fn values(m: &SymbolicModel, e: &lincal_core::calibrate::estimate::Estimate) -> Vec<f64> {
    (0..m.param_count())
        .map(|j| {
            e.params
                .iter()
                .find(|q| q.name == m.param_name(j))
                .map_or(m.param_nominal(j), |q| q.value)
        })
        .collect()
}

/// RMS distance between the tips of `p` and of the truth `t` over fresh readings.
fn tip_error(m: &SymbolicModel, p: &[f64], t: &[f64]) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let mut sum = 0.0;
    let n = 2000;
    for _ in 0..n {
        let q: Vec<f64> = (0..4)
            .map(|_| 2.5 * (2.0 * rng.gen::<f64>() - 1.0))
            .collect();
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        m.tip(&q, p, &mut a);
        m.tip(&q, t, &mut b);
        sum += (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    }
    (sum / f64::from(n)).sqrt()
}

/// With the default options the error falls like `1/√N`, and at `N = 10⁴` it is within 2 %
/// of the plain least-squares fit's: the prior fades (the relative prior it replaces was
/// 7× worse there on a tracker bench).
#[test]
fn the_default_prior_fades_as_the_poses_grow() {
    let (spec, m) = model(&spec(1));
    let t = truth(&m);
    let mut errors = Vec::new();
    for (n, seed) in [(100, 1), (1_000, 2), (10_000, 3)] {
        let poses = tracker_data(&m, &t, n, 50e-6, 0.0, seed);
        let default = fit(&spec, &m, &poses, PriorChoice::default());
        assert!(default.prior.applied, "{:?}", default.prior);
        assert!(default.prior.selection.is_some());
        let plain = fit(&spec, &m, &poses, PriorChoice::Off);
        let (e_default, e_plain) = (
            tip_error(&m, &values(&m, &default), &t),
            tip_error(&m, &values(&m, &plain), &t),
        );
        eprintln!("N = {n}: default {e_default:.3e}, plain {e_plain:.3e}");
        errors.push((e_default, e_plain));
    }
    let (at_big, plain_big) = errors[2];
    assert!(
        at_big <= 1.02 * plain_big,
        "N = 10⁴: {at_big:e} against the plain fit's {plain_big:e}"
    );
    // 100 times the poses: the error a tenth (1/√N), within what one draw of each allows.
    let ratio = errors[0].0 / errors[2].0;
    assert!(
        (5.0..20.0).contains(&ratio),
        "error ratio 100 → 10⁴: {ratio}"
    );
}

/// The 4R arm on `sockets` pinned points, each point unknown (its nominal `nominal[j]`).
fn socket_spec(nominal: &[[f64; 3]]) -> String {
    let base = spec(1);
    let mut s = base[..base.find("constraint:").unwrap()].to_string();
    for (j, p) in nominal.iter().enumerate() {
        for (c, v) in ["x", "y", "z"].iter().zip(p) {
            s.push_str(&format!("  s{j}{c}: {{nominal: {v}}}\n"));
        }
    }
    s.push_str("constraints:\n");
    for j in 0..nominal.len() {
        s.push_str(&format!("  - point: {{p: [s{j}x, s{j}y, s{j}z]}}\n"));
    }
    s
}

/// The readings whose sagging arm ([`tracker_data`]'s sag) stands at `bent`.
fn unbent(bent: &[f64], sag: f64) -> Vec<f64> {
    let mut q = bent.to_vec();
    for _ in 0..50 {
        q[1] = bent[1] - sag * q[1].cos();
        q[2] = bent[2] - sag * (q[1] + q[2]).cos();
    }
    q
}

/// `per` poses on each socket of `arm` at `truth` (the sockets' points its last
/// parameters), readings with `encoder` noise, the arm sagging by `sag`.
fn socket_data(
    arm: &SymbolicModel,
    t: &[f64],
    refs: &[Vec<f64>],
    per: usize,
    encoder: f64,
    sag: f64,
    seed: u64,
) -> Poses {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut poses = Poses::default();
    let mut l = 0;
    for (j, r) in refs.iter().enumerate() {
        let mut placed = 0;
        while placed < per {
            let q0: Vec<f64> = r
                .iter()
                .map(|v| v + 0.8 * (2.0 * rng.gen::<f64>() - 1.0))
                .collect();
            let Some(bent) = super::sim::place(arm, j, t, &q0, &[0.0; 3]) else {
                continue;
            };
            let q: Vec<f64> = unbent(&bent, sag)
                .iter()
                .map(|v| v + encoder * gauss(&mut rng))
                .collect();
            poses.q.push(&q);
            poses.constraint.push(j);
            poses.line.push(l + 2);
            l += 1;
            placed += 1;
        }
    }
    poses
}

/// The choice starts from the looser of the drawing's tolerance and MUKCa's relative ridge
/// `σ̂/√(N·10⁻⁴)`: on 30 tracker poses with 2 mm of noise that ridge (about 3.7 cm) is the start,
/// on the curve, and the clusters of one placement may only weaken it; on 1 000 poses with
/// 50 µm the drawing's 1 cm is (the ridge would be 0.16 mm there: the start's information stays
/// bounded, so the prior fades).
#[test]
fn the_choice_starts_no_tighter_than_the_relative_ridge() {
    use lincal_core::calibrate::prior::{StrengthRule, UNSEEN_TOLERANCE};
    let (spec, m) = model(&spec(1));
    let t = truth(&m);
    for (n, noise, seed) in [(30, 2e-3, 11), (1_000, 50e-6, 12)] {
        let poses = tracker_data(&m, &t, n, noise, 0.0, seed);
        let e = fit(&spec, &m, &poses, PriorChoice::default());
        let sel = e.prior.selection.expect("the data chose the prior");
        let sigma = e.prior.sigma.expect("the noise level");
        let ridge = sigma / (n as f64 * 1e-4).sqrt();
        eprintln!("N = {n}: σ̂ {sigma:.3e}, ridge {ridge:.3e}, {sel:?}");
        if ridge > UNSEEN_TOLERANCE {
            assert!(
                (sel.start / ridge - 1.0).abs() < 1e-9,
                "start {}",
                sel.start
            );
            assert!(
                sel.curve
                    .iter()
                    .any(|c| (c.tolerance / ridge - 1.0).abs() < 1e-9),
                "the start on the curve"
            );
        } else {
            assert_eq!(sel.start, UNSEEN_TOLERANCE);
        }
        assert!(
            n > 100 || ridge > 2.0 * UNSEEN_TOLERANCE,
            "the case tests the ridge: {ridge}"
        );
        if let (StrengthRule::Scale, Some(tol)) = (sel.rule, sel.tolerance) {
            assert!(
                tol >= sel.start * (1.0 - 1e-12),
                "{tol} below the start {}",
                sel.start
            );
        }
    }
}

/// On placements whose data carry an error the model cannot hold (joint sag under gravity),
/// the grouped choice holds the arm harder than on white-noise data of the same size.
#[test]
fn a_systematic_error_makes_the_grouped_choice_stronger() {
    let refs: Vec<Vec<f64>> = (0..4)
        .map(|j| vec![-1.2 + 0.8 * f64::from(j), 0.6, -0.9, 0.3])
        .collect();
    let (spec, m, t) = sockets_at(&refs);
    let white = socket_data(&m, &t, &refs, 20, 50e-6, 0.0, 5);
    let sagging = socket_data(&m, &t, &refs, 20, 50e-6, 1.5e-3, 5);
    let held = |poses: &Poses| {
        let e = fit(&spec, &m, poses, PriorChoice::default());
        let sel = e.prior.selection.expect("the data chose the prior");
        assert_eq!(sel.folds, 4, "one fold per placement");
        eprintln!("{sel:?}");
        sel.held
    };
    let (h_white, h_sag) = (held(&white), held(&sagging));
    assert!(
        h_sag > h_white,
        "held by the prior: {h_sag} with sag, {h_white} on white noise"
    );
}

/// The lack-of-fit statistic is calibrated: on data the model holds (white noise only) the
/// drawing's held-out sum of squares over the clusters equals its expectation (noise plus the
/// estimate's own variance at the held-out readings) within its own spread, and never counts
/// as systematic; an error the model cannot hold (the arm's joints sag under gravity) takes
/// it far beyond, and the tolerance then comes from the residual level.
#[test]
fn the_lack_of_fit_test_tells_noise_from_an_error_the_model_cannot_hold() {
    use lincal_core::calibrate::prior::{residual_tolerance, StrengthRule, SYSTEMATIC_Z};
    let (arm_spec, arm) = model(&spec(1));
    let t_arm = truth(&arm);
    // Two sockets a joint-space step apart: one placement, as MUKCa's.
    let refs: Vec<Vec<f64>> = (0..2)
        .map(|j| vec![-0.4 + 0.8 * f64::from(j), 0.6, -0.9, 0.3])
        .collect();
    let (sockets_spec, sockets, t_sockets) = sockets_at(&refs);
    let mut tracker_ratio = 0.0;
    // Seed 6: a fold the others barely predict (leverage 187 over 93 rows), whose sum of
    // squares is a heavy-tailed weighted `χ²`; a test without its variance flagged it.
    let seeds = [5, 6, 7, 100, 101, 102];
    for seed in seeds {
        // White noise: a tracker over the whole workspace, and two sockets (encoder noise).
        for (name, spec, m, poses) in [
            (
                "tracker",
                &arm_spec,
                &arm,
                tracker_data(&arm, &t_arm, 100, 50e-6, 0.0, seed),
            ),
            (
                "sockets",
                &sockets_spec,
                &sockets,
                socket_data(&sockets, &t_sockets, &refs, 40, 50e-6, 0.0, seed),
            ),
        ] {
            let sel = fit(spec, m, &poses, PriorChoice::default())
                .prior
                .selection
                .expect("the data chose the prior");
            let lof = sel.lack_of_fit.expect("clusters report the lack of fit");
            eprintln!("{name}, seed {seed}: {lof:?}");
            assert!(
                lof.sigmas < SYSTEMATIC_Z && sel.rule != StrengthRule::Residual,
                "{name}, seed {seed}: white noise counted as systematic, {lof:?}"
            );
            if name == "tracker" {
                tracker_ratio += lof.ratio / seeds.len() as f64;
            }
        }
    }
    assert!(
        (tracker_ratio - 1.0).abs() < 0.1,
        "mean lack of fit on white noise {tracker_ratio}"
    );
    // The arm sags by 30 mrad at the horizontal: the sockets' clusters see it differently.
    for seed in 0..3 {
        let poses = socket_data(&sockets, &t_sockets, &refs, 40, 50e-6, 3e-2, 100 + seed);
        let e = fit(&sockets_spec, &sockets, &poses, PriorChoice::default());
        let sigma = e.prior.sigma.expect("the prior's noise level");
        let sel = e.prior.selection.expect("the data chose the prior");
        let lof = sel.lack_of_fit.expect("clusters report the lack of fit");
        eprintln!("sagging sockets, seed {seed}: {lof:?}");
        assert!(lof.sigmas > SYSTEMATIC_Z, "seed {seed}: {lof:?}");
        assert_eq!(sel.rule, StrengthRule::Residual);
        let tol = sel.tolerance.expect("one scale");
        assert!(
            (tol / residual_tolerance(sigma) - 1.0).abs() < 1e-12,
            "{tol} against σ̂ {sigma}"
        );
    }
}

/// The 4R arm on unknown sockets, one taught at each reading of `refs` (its nominal 5 mm
/// off), and its truth (the arm's, then the sockets' points).
fn sockets_at(refs: &[Vec<f64>]) -> (lincal_core::spec::Spec, SymbolicModel, Vec<f64>) {
    let (_, arm) = model(&spec(1));
    let t_arm = truth(&arm);
    let points: Vec<[f64; 3]> = refs
        .iter()
        .map(|q| {
            let mut x = [0.0; 3];
            arm.tip(q, &t_arm, &mut x);
            x
        })
        .collect();
    let nominal: Vec<[f64; 3]> = points.iter().map(|p| p.map(|v| v + 0.005)).collect();
    let (spec, m) = model(&socket_spec(&nominal));
    let t = with_points(&m, truth(&m), &points);
    (spec, m, t)
}

/// `t` with the sockets' points `s{j}x, s{j}y, s{j}z` set to `points`.
fn with_points(m: &SymbolicModel, mut t: Vec<f64>, points: &[[f64; 3]]) -> Vec<f64> {
    for (j, p) in points.iter().enumerate() {
        for (c, v) in ["x", "y", "z"].iter().zip(p) {
            let k = (0..m.param_count())
                .find(|&k| m.param_name(k) == format!("s{j}{c}"))
                .expect("a socket's coordinate");
            t[k] = *v;
        }
    }
    t
}

/// The estimate is a continuous function of the prior's strength: a 0.1 % change of the
/// tolerances moves it by a small part of what a 10 % change does, at every scale (a prior
/// switched on per parameter jumps where a parameter crosses its tolerance).
#[test]
fn the_estimate_is_continuous_in_the_strength() {
    let (spec, m) = model(&spec(1));
    let t = truth(&m);
    let poses = tracker_data(&m, &t, 40, 100e-6, 0.0, 7);
    let at = |tol: f64| {
        values(
            &m,
            &fit(
                &spec,
                &m,
                &poses,
                PriorChoice::On {
                    scale: PriorScale::Tolerances {
                        length: tol,
                        angle: tol,
                    },
                    shape: PriorShape::Frames,
                },
            ),
        )
    };
    let dist = |a: &[f64], b: &[f64]| -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    for tol in [1e-5, 1e-4, 1e-3, 1e-2, 1e-1] {
        let p = at(tol);
        let small = dist(&p, &at(tol * 1.001));
        let big = dist(&p, &at(tol * 1.1));
        assert!(
            small <= 0.05 * big + 1e-12,
            "tolerance {tol}: {small:e} for 0.1 %, {big:e} for 10 %"
        );
    }
    // A weak relative prior is still a prior: it is not the fit without one.
    let weak = fit(
        &spec,
        &m,
        &poses,
        PriorChoice::On {
            scale: PriorScale::Weight(1e-5),
            shape: PriorShape::Frames,
        },
    );
    let off = fit(&spec, &m, &poses, PriorChoice::Off);
    assert!(weak.prior.applied);
    assert!(dist(&values(&m, &weak), &values(&m, &off)) > 0.0);
}

/// Beyond 20 000 poses the clusters' centers come from an evenly strided sample, then every
/// pose takes its nearest: the folds still cover every pose, none empty, the same twice,
/// and a pose repeated exactly lands in its twin's fold.
#[test]
fn clusters_of_many_poses_cover_every_pose_from_a_sample() {
    use lincal_core::calibrate::grouping;
    let (_, m) = model(&spec(1));
    let p: Vec<f64> = (0..m.param_count()).map(|j| m.param_nominal(j)).collect();
    let mut poses = tracker_data(&m, &p, 30_000, 1e-5, 0.0, 11);
    // Pose 29 999 repeats pose 1 (not a multiple of the sample's stride).
    let first = poses.q.get(1).expect("pose 1").to_vec();
    let mut q = Rows::new(poses.q.width());
    for (l, row) in poses.q.iter().enumerate() {
        q.push(if l == 29_999 { &first } else { row });
    }
    poses.q = q;
    let a = grouping::clusters(&m, &poses, 5);
    assert_eq!(a, grouping::clusters(&m, &poses, 5));
    assert_eq!(a.fold.len(), 30_000);
    assert_eq!(a.folds, 5);
    for f in 0..a.folds {
        assert!(a.fold.contains(&f), "fold {f} is empty");
    }
    assert_eq!(a.fold[29_999], a.fold[1]);
}
