//! The parameter-space path (issue 9): mirrored solutions come back canonical, near-lost
//! combinations are reported, and the start is chosen by the stated rule.

use super::sim::{simulate, SimOptions};
use lincal_core::calibrate::prior::PriorChoice;
use lincal_core::calibrate::{calibrate_spec, CalibrateOptions, StartChoice};
use lincal_core::numeric::wrap_angle;
use lincal_core::symbolic::SymbolicModel;
use lincal_core::CalibModel;

/// A spatial 4R arm in modified DH, every a, α, d, home unknown, measured tips.
const MDH4: &str = "name: mdh4
dim: 3
convention: mdh
joints:
  - {type: revolute, a: a1, alpha: al1, d: d1, home: th1}
  - {type: revolute, a: a2, alpha: al2, d: d2, home: th2}
  - {type: revolute, a: a3, alpha: al3, d: d3, home: th3}
  - {type: revolute, a: a4, alpha: al4, d: d4, home: th4}
tool: [0.05, 0.02, 0.1]
params:
  a1: {nominal: 0.02}
  al1: {nominal: 0.01}
  d1: {nominal: 0.3}
  th1: {nominal: 0.01}
  a2: {nominal: 0.05}
  al2: {nominal: -1.5707963267948966}
  d2: {nominal: 0.02}
  th2: {nominal: -0.02}
  a3: {nominal: 0.4}
  al3: {nominal: 0.02}
  d3: {nominal: 0.1}
  th3: {nominal: 0.03}
  a4: {nominal: 0.03}
  al4: {nominal: 1.5707963267948966}
  d4: {nominal: 0.35}
  th4: {nominal: -0.01}
constraint:
  measured: {}
";

fn model(yaml: &str) -> (lincal_core::spec::Spec, SymbolicModel) {
    let spec = lincal_core::spec::from_yaml_str(yaml, None).unwrap();
    let m = SymbolicModel::from_spec(&spec).unwrap();
    (spec, m)
}

fn truth(m: &SymbolicModel) -> Vec<f64> {
    off_the_nominals(m, |nom| 0.02 * nom.abs().max(0.05))
}

/// Every free parameter moved off its nominal by up to `size(nominal)`, a fixed pattern of
/// signs and fractions.
fn off_the_nominals(m: &SymbolicModel, size: fn(f64) -> f64) -> Vec<f64> {
    (0..m.param_count())
        .map(|j| {
            let nom = m.param_nominal(j);
            if m.param_held(j) {
                nom
            } else {
                let s = ((j * 7919 % 13) as f64 / 12.0) * 2.0 - 1.0;
                nom + s * size(nom)
            }
        })
        .collect()
}

fn assert_same(m: &SymbolicModel, got: &[f64], want: &[f64], tol: f64) {
    for j in 0..m.param_count() {
        let d = if m.param_is_angle(j) {
            wrap_angle(got[j] - want[j])
        } else {
            got[j] - want[j]
        };
        assert!(
            d.abs() <= tol,
            "{}: {} vs {} (diff {d:e})",
            m.param_name(j),
            got[j],
            want[j]
        );
    }
}

#[test]
fn mirrored_links_come_back_canonical() {
    let (_, m) = model(MDH4);
    let t = truth(&m);
    let idx = |n: &str| {
        (0..m.param_count())
            .find(|&j| m.param_name(j) == n)
            .unwrap()
    };
    // MDH mirror at link 3: α3, a3 negated, the homes on both sides shifted by π.
    let mut mirrored = t.clone();
    for n in ["al3", "a3"] {
        mirrored[idx(n)] = -mirrored[idx(n)];
    }
    for n in ["th2", "th3"] {
        mirrored[idx(n)] += std::f64::consts::PI;
    }
    let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
    for s in 0..5 {
        let q: Vec<f64> = (0..4)
            .map(|i| 0.3 * f64::from(s) - 0.7 * i as f64)
            .collect();
        m.tip(&q, &t, &mut a);
        m.tip(&q, &mirrored, &mut b);
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-12, "the mirror moves the tip");
        }
    }
    assert!(!lincal_core::fit::symmetry::generators(&m, &mirrored).is_empty());
    let mut p = mirrored.clone();
    let flips = lincal_core::fit::symmetry::canonicalize(&m, &mut p, 0.5);
    assert!(flips > 0);
    assert_same(&m, &p, &t, 1e-12);
}

#[test]
fn far_start_lands_on_the_canonical_solution() {
    // Home offsets 2-3 rad off: the fit from the nominals must still end at the truth (or an
    // exact equivalent, reported canonically).
    let far = MDH4
        .replace("th2: {nominal: -0.02}", "th2: {nominal: 2.5}")
        .replace("th3: {nominal: 0.03}", "th3: {nominal: -2.8}");
    let (spec0, m0) = model(MDH4);
    let t = truth(&m0);
    let poses = simulate(&m0, &t, SimOptions::new(60, 5));
    let (spec, m) = model(&far);
    let est = calibrate_spec(
        &m,
        &spec,
        &poses,
        CalibrateOptions {
            refine: false,
            start: StartChoice::Nominal,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(est.residual_rms < 1e-9, "residual {:e}", est.residual_rms);
    // Lengths keep their nominal signs; the tips are the truth's.
    let p: Vec<f64> = est.params.iter().map(|q| q.value).collect();
    let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
    for q in poses.q.iter().take(10) {
        m0.tip(q, &t, &mut a);
        m.tip(q, &p, &mut b);
        for i in 0..3 {
            assert!((a[i] - b[i]).abs() < 1e-9);
        }
    }
    for (j, v) in p.iter().enumerate() {
        if !m.param_is_angle(j) && m.param_nominal(j) != 0.0 {
            assert_eq!(
                v.signum(),
                m.param_nominal(j).signum(),
                "{}",
                m.param_name(j)
            );
        }
    }
    let _ = spec0;
}

/// The 4R arm with z2 and z3 nearly parallel (α3 = 0.002 rad): d2 and d3 separate only
/// through that twist. The spec, the model, the truth and 80 poses with 50 µm noise.
fn near_lost_pair() -> (
    lincal_core::spec::Spec,
    SymbolicModel,
    Vec<f64>,
    lincal_core::data::Poses,
) {
    near_lost_pair_off_by(truth)
}

/// A truth off the nominals as a real arm's drawing is: by up to 0.5 mm and 0.5 mrad.
fn drawing_truth(m: &SymbolicModel) -> Vec<f64> {
    off_the_nominals(m, |_| 5e-4)
}

/// [`near_lost_pair`] with the truth `truth_of` gives.
fn near_lost_pair_off_by(
    truth_of: fn(&SymbolicModel) -> Vec<f64>,
) -> (
    lincal_core::spec::Spec,
    SymbolicModel,
    Vec<f64>,
    lincal_core::data::Poses,
) {
    let yaml = MDH4.replace("al3: {nominal: 0.02}", "al3: {nominal: 0.002}");
    let (spec, m) = model(&yaml);
    let mut t = truth_of(&m);
    let al3 = (0..m.param_count())
        .find(|&j| m.param_name(j) == "al3")
        .unwrap();
    t[al3] = 0.002;
    let poses = simulate(
        &m,
        &t,
        SimOptions {
            measure: 50e-6,
            ..SimOptions::new(80, 9)
        },
    );
    (spec, m, t, poses)
}

/// RMS distance between the tips of `p` and of the truth `t` at 200 fresh noise-free poses.
fn tip_error(m: &SymbolicModel, t: &[f64], p: &[f64]) -> f64 {
    let fresh = simulate(m, t, SimOptions::new(200, 77));
    let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
    let mut sum = 0.0;
    for q in &fresh.q {
        m.tip(q, t, &mut a);
        m.tip(q, p, &mut b);
        sum += (0..3).map(|i| (a[i] - b[i]).powi(2)).sum::<f64>();
    }
    (sum / fresh.len() as f64).sqrt()
}

/// The frame prior with fixed tolerances of 1 cm and 0.01 rad (a Bayesian prior).
fn fixed_prior() -> PriorChoice {
    use lincal_core::calibrate::prior::{
        PriorScale, PriorShape, DEFAULT_ANGLE_TOLERANCE, DEFAULT_LENGTH_TOLERANCE,
    };
    PriorChoice::On {
        scale: PriorScale::Tolerances {
            length: DEFAULT_LENGTH_TOLERANCE,
            angle: DEFAULT_ANGLE_TOLERANCE,
        },
        shape: PriorShape::Frames,
    }
}

fn value(e: &lincal_core::calibrate::estimate::Estimate, n: &str) -> f64 {
    e.params.iter().find(|q| q.name == n).unwrap().value
}

/// MUKCa's relative prior (`--prior-weight`), `(1/N)·Σ‖g‖² + w·‖ξ‖²`: the same poses measured
/// twice give the same estimate (a fixed prior fades as they are repeated). On an arm off
/// its drawing by what real arms are (0.5 mm, 0.5 mrad), it holds the near lost pair within
/// its tolerance `σ̂/√(N·w)` of the truth, with tips no worse than with the direction free.
#[test]
fn a_relative_prior_is_relative_to_the_data() {
    let relative = PriorChoice::On {
        scale: lincal_core::calibrate::prior::PriorScale::Weight(1e-4),
        shape: lincal_core::calibrate::prior::PriorShape::Frames,
    };
    let (spec, m, t, poses) = near_lost_pair_off_by(drawing_truth);
    let twice: Vec<usize> = (0..poses.len()).flat_map(|l| [l, l]).collect();
    let doubled = poses.select(&twice);
    let fit = |p: &lincal_core::data::Poses, prior| {
        calibrate_spec(
            &m,
            &spec,
            p,
            CalibrateOptions {
                prior,
                refine: true,
                ..Default::default()
            },
        )
        .unwrap()
    };
    let (once, again) = (fit(&poses, relative), fit(&doubled, relative));
    assert!(
        once.prior.applied && again.prior.applied,
        "{:?}",
        once.prior
    );
    assert_eq!(once.prior.weak, again.prior.weak);
    assert_eq!(once.prior.weight, Some(1e-4));
    for (a, b) in once.params.iter().zip(&again.params) {
        assert!(
            (a.value - b.value).abs() < 1e-7,
            "{}: {} once, {} twice",
            a.name,
            a.value,
            b.value
        );
    }
    // A fixed prior is not: the repeated poses weigh twice against it.
    let (f1, f2) = (fit(&poses, fixed_prior()), fit(&doubled, fixed_prior()));
    assert!(f1.prior.applied && f2.prior.applied);
    assert!(
        (value(&f1, "d2") - value(&f2, "d2")).abs() > 1e-5,
        "{} {}",
        value(&f1, "d2"),
        value(&f2, "d2")
    );
    // The tolerance it came to, and the pair held near the nominals.
    let sigma = once.prior.sigma.unwrap();
    let tau = once.prior.length_tolerance.unwrap();
    assert!((tau - sigma / (poses.len() as f64 * 1e-4).sqrt()).abs() < 1e-12);
    held_near_the_truth(&m, &t, &once, &fit(&poses, PriorChoice::Off), tau);
}

/// With the prior (`held`), `d2` and `d3` end within `tol` of the truth `t` and nearer it than
/// free (`off`), and the tips are no worse than free.
fn held_near_the_truth(
    m: &SymbolicModel,
    t: &[f64],
    held: &lincal_core::calibrate::estimate::Estimate,
    off: &lincal_core::calibrate::estimate::Estimate,
    tol: f64,
) {
    for n in ["d2", "d3"] {
        let j = (0..m.param_count())
            .find(|&j| m.param_name(j) == n)
            .unwrap();
        assert!(
            (value(held, n) - t[j]).abs() < tol,
            "{n}: {} against {}",
            value(held, n),
            t[j]
        );
        assert!((value(off, n) - t[j]).abs() > (value(held, n) - t[j]).abs());
    }
    let p = |e: &lincal_core::calibrate::estimate::Estimate| -> Vec<f64> {
        e.params.iter().map(|q| q.value).collect()
    };
    let (a, b) = (tip_error(m, t, &p(held)), tip_error(m, t, &p(off)));
    assert!(a <= 1.05 * b, "tip error {a:e} held, {b:e} free");
}

#[test]
fn near_lost_pair_is_held_by_a_fixed_prior() {
    let (spec, m, t, poses) = near_lost_pair();
    let off = calibrate_spec(
        &m,
        &spec,
        &poses,
        CalibrateOptions {
            prior: PriorChoice::Off,
            ..Default::default()
        },
    )
    .unwrap();
    let est = calibrate_spec(
        &m,
        &spec,
        &poses,
        CalibrateOptions {
            prior: fixed_prior(),
            ..Default::default()
        },
    )
    .unwrap();
    assert!(est.prior.applied, "{:?}", est.prior);
    assert!(
        ["d2", "d3"]
            .iter()
            .all(|n| est.prior.weak.iter().any(|w| w == n)),
        "{:?}",
        est.prior.weak
    );
    // Free, the pair runs off along the weak direction; held, it stays within its
    // tolerance of the truth (which is within 1 mm of the nominals).
    // The tips are no worse than with the direction free.
    let tol = lincal_core::calibrate::prior::DEFAULT_LENGTH_TOLERANCE;
    held_near_the_truth(&m, &t, &est, &off, tol);
    // The reported std of the held pair is the posterior's: at most about the tolerance.
    for q in est
        .params
        .iter()
        .filter(|q| q.name == "d2" || q.name == "d3")
    {
        assert!(q.std.is_some_and(|s| s <= 1.01 * tol), "{q:?}");
    }
}

/// The default prior, chosen from the data, holds the near lost pair too: within the default
/// tolerance of the truth, nearer it than free, the tips no worse.
#[test]
fn near_lost_pair_is_held_by_the_default_prior() {
    let (spec, m, t, poses) = near_lost_pair();
    let fit = |prior| {
        calibrate_spec(
            &m,
            &spec,
            &poses,
            CalibrateOptions {
                prior,
                ..Default::default()
            },
        )
        .unwrap()
    };
    let (est, off) = (fit(PriorChoice::default()), fit(PriorChoice::Off));
    assert!(est.prior.applied, "{:?}", est.prior);
    assert!(est.prior.selection.is_some());
    let tol = lincal_core::calibrate::prior::DEFAULT_LENGTH_TOLERANCE;
    held_near_the_truth(&m, &t, &est, &off, tol);
}

#[test]
fn near_lost_pair_is_reported_with_the_prior_off() {
    let (spec, m, _, poses) = near_lost_pair();
    let est = calibrate_spec(
        &m,
        &spec,
        &poses,
        CalibrateOptions {
            prior: PriorChoice::Off,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(!est.prior.applied);
    let w = est
        .warnings
        .iter()
        .find(|w| w.contains("practically unidentifiable"))
        .unwrap_or_else(|| panic!("no warning: {:?}", est.warnings));
    assert!(w.contains("d2") && w.contains("d3"), "{w}");
    assert!(est.condition.unwrap() > 1e3);
}

#[test]
fn start_follows_the_rule() {
    let (spec, m) = model(MDH4);
    let t = truth(&m);
    let k = m.basis_size();
    // Fewer poses than K: the nominals.
    let few = simulate(&m, &t, SimOptions::new(30, 1));
    assert!(few.len() < k);
    let est = calibrate_spec(&m, &spec, &few, CalibrateOptions::default()).unwrap();
    assert_eq!((est.start.as_str(), est.linear_poses), ("nominal", 0));
    // Asking for the linear method there is an error that says why.
    let e = calibrate_spec(
        &m,
        &spec,
        &few,
        CalibrateOptions {
            refine: false,
            start: StartChoice::Linear,
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("K ="), "{e}");
    // Enough poses for an affordable linear solve: the linear method, no initial guess.
    let many = simulate(&m, &t, SimOptions::new(2 * k, 2));
    let est = calibrate_spec(&m, &spec, &many, CalibrateOptions::default()).unwrap();
    assert_eq!(est.start, "linear");
    assert_eq!(est.linear_poses, many.len());
    assert_same(
        &m,
        &est.params.iter().map(|q| q.value).collect::<Vec<_>>(),
        &t,
        1e-9,
    );
}
