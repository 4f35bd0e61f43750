//! Planar arms with hand-coded models: a line (paper sec. 4.1), a pinned point (sec. 4.2),
//! measured tips. Noise-free data must give every identifiable combination to 1e-9, noisy
//! data must land within 3σ of the reported standard deviations.

use super::models::{self_check, Kind, PlanarArm};
use super::sim::{simulate, SimOptions};
use lincal_core::calibrate::estimate::Estimate;
use lincal_core::calibrate::{calibrate, CalibrateOptions};
use lincal_core::numeric::wrap_angle;
use lincal_core::CalibModel;

pub fn value(est: &Estimate, name: &str) -> f64 {
    est.params.iter().find(|p| p.name == name).unwrap().value
}

pub fn std_of(est: &Estimate, name: &str) -> f64 {
    est.params
        .iter()
        .find(|p| p.name == name)
        .unwrap()
        .std
        .unwrap()
}

const A: [f64; 4] = [0.4, 0.3, 0.2, 0.15];
const TH: [f64; 4] = [0.05, -0.031, 0.052, 0.2];

/// True parameters of an n-link arm with the constraint parameters `(u, v)`.
fn truth(n: usize, u: f64, v: f64) -> Vec<f64> {
    let mut p = Vec::new();
    for i in 0..n {
        p.push(A[i]);
        p.push(TH[i]);
    }
    p.push(u);
    p.push(v);
    p
}

/// Nominals: the gauge (a1, th1) away from the truth, the rest perturbed.
fn nominal(truth: &[f64], n: usize, gauge_off: bool) -> Vec<f64> {
    let mut p = truth.to_vec();
    if gauge_off {
        p[0] *= 0.9;
        p[1] += 0.3;
    }
    for i in 1..n {
        p[2 * i] *= 1.07;
        p[2 * i + 1] += 0.04;
    }
    p[2 * n] *= 0.8;
    p[2 * n + 1] *= 1.2;
    p
}

fn line_combos(names_p: &dyn Fn(&str) -> f64, n: usize) -> Vec<(String, f64, bool)> {
    let a1 = names_p("a1");
    let mut out = Vec::new();
    for i in 2..=n {
        out.push((format!("a{i}/a1"), names_p(&format!("a{i}")) / a1, false));
        out.push((format!("th{i}"), names_p(&format!("th{i}")), true));
    }
    out.push((
        "beta+th1".into(),
        names_p("b2").atan2(names_p("b1")) + names_p("th1"),
        true,
    ));
    out.push((
        "a1*|b|".into(),
        a1 * names_p("b1").hypot(names_p("b2")),
        false,
    ));
    out
}

fn point_combos(names_p: &dyn Fn(&str) -> f64, n: usize) -> Vec<(String, f64, bool)> {
    let a1 = names_p("a1");
    let mut out = Vec::new();
    for i in 2..=n {
        out.push((format!("a{i}/a1"), names_p(&format!("a{i}")) / a1, false));
        out.push((format!("th{i}"), names_p(&format!("th{i}")), true));
    }
    out.push((
        "gamma+th1".into(),
        names_p("py").atan2(names_p("px")) + names_p("th1"),
        true,
    ));
    out.push((
        "|p|/a1".into(),
        names_p("px").hypot(names_p("py")) / a1,
        false,
    ));
    out
}

fn check_combos(got: &[(String, f64, bool)], want: &[(String, f64, bool)], tol: f64) {
    assert_eq!(got.len(), want.len());
    for ((name, g, angle), (_, w, _)) in got.iter().zip(want) {
        let d = if *angle { wrap_angle(g - w) } else { g - w };
        assert!(d.abs() <= tol, "{name}: got {g}, want {w} (diff {d:e})");
    }
}

fn by_name<'a>(model: &'a PlanarArm, p: &'a [f64]) -> impl Fn(&str) -> f64 + 'a {
    move |n: &str| p[model.index(n)]
}

fn est_by_name(est: &Estimate) -> impl Fn(&str) -> f64 + '_ {
    move |n: &str| value(est, n)
}

#[test]
fn hand_coded_models_are_consistent() {
    let q = [0.3, -1.2, 0.7];
    for kind in [Kind::Line, Kind::Point, Kind::Measured] {
        let p = truth(3, -1.8, 1.0);
        let m = PlanarArm::new(3, kind, p.clone());
        self_check(&m, &p, &q);
    }
}

#[test]
fn line_noise_free_recovers_combinations() {
    for n in [2, 3, 4] {
        let t = truth(n, -1.8, 1.0);
        let model = PlanarArm::new(n, Kind::Line, nominal(&t, n, true));
        let poses = simulate(&model, &t, SimOptions::new(60, 7 + n as u64));
        for refine in [false, true] {
            let est = calibrate(
                &model,
                &model.spec_params(),
                &poses,
                CalibrateOptions {
                    refine,
                    ..Default::default()
                },
            )
            .unwrap();
            let got = line_combos(&est_by_name(&est), n);
            let want = line_combos(&by_name(&model, &t), n);
            check_combos(&got, &want, 1e-9);
            assert!(est.residual_rms < 1e-10, "residual {}", est.residual_rms);
            assert!(est.paper_err_rms.unwrap() < 1e-10);
            assert_eq!(est.basis_size, Some(2 * n + 1));
            assert_eq!(est.rank, 2 * n, "noise-free data on one line: rank K - 1");
            assert_eq!(est.method, if refine { "linear+refine" } else { "linear" });
            // The gauge: a1, th1 held at the nominal, flagged, no std.
            let a1 = &est.params[0];
            assert!(a1.held && a1.std.is_none() && !a1.identifiable);
            assert_eq!(a1.value, model.nominal[0]);
            // The paper's normalised linear solution is c(p), which is gauge invariant.
            let mut c = vec![0.0; 2 * n + 1];
            model.generalized_params(&t, &mut c);
            for (g, w) in est.generalized_params.iter().zip(&c) {
                assert!((g - w).abs() < 1e-9 * (1.0 + w.abs()), "c: {g} vs {w}");
            }
        }
    }
}

#[test]
fn point_noise_free_recovers_six_combinations() {
    let n = 3;
    let t = truth(n, 0.35, 0.25);
    let model = PlanarArm::new(n, Kind::Point, nominal(&t, n, true));
    let poses = simulate(&model, &t, SimOptions::new(40, 3));
    let est = calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions::default(),
    )
    .unwrap();
    let got = point_combos(&est_by_name(&est), n);
    let want = point_combos(&by_name(&model, &t), n);
    assert_eq!(got.len(), 6);
    check_combos(&got, &want, 1e-9);
    assert_eq!(est.identifiable_count, 6);
    // Two equations vanish on the data: a 2-D null space.
    assert_eq!(est.rank, 2 * n + 1 - 2);
    // The homogeneous linear solve's subspace contains c_x(p) and c_y(p).
    let k = 2 * n + 1;
    let mut c = vec![0.0; 2 * k];
    model.generalized_params(&t, &mut c);
    let basis: Vec<nalgebra::DVector<f64>> = (0..2)
        .map(|e| nalgebra::DVector::from_column_slice(&est.generalized_params[e * k..(e + 1) * k]))
        .collect();
    let gram = nalgebra::DMatrix::from_fn(k, 2, |r, col| basis[col][r]);
    for e in 0..2 {
        let ce = nalgebra::DVector::from_column_slice(&c[e * k..(e + 1) * k]);
        let coef = gram.clone().svd(true, true).solve(&ce, 1e-12).unwrap();
        let resid = (&gram * coef - &ce).norm() / ce.norm();
        assert!(
            resid < 1e-9,
            "c_{e} not in the linear null subspace: {resid:e}"
        );
    }
    // The refined fit agrees.
    let est = calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions {
            refine: true,
            ..Default::default()
        },
    )
    .unwrap();
    check_combos(&point_combos(&est_by_name(&est), n), &want, 1e-9);
}

#[test]
fn measured_noise_free_recovers_every_parameter() {
    let n = 3;
    let t = truth(n, 0.1, -0.05);
    let mut nom = t.clone();
    for (i, v) in nom.iter_mut().enumerate() {
        *v += 0.02 * (i as f64 + 1.0).sin();
    }
    let model = PlanarArm::new(n, Kind::Measured, nom);
    let poses = simulate(&model, &t, SimOptions::new(30, 5));
    let est = calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions::default(),
    )
    .unwrap();
    for (j, w) in t.iter().enumerate() {
        let g = est.params[j].value;
        assert!((g - w).abs() < 1e-9, "{}: {g} vs {w}", est.params[j].name);
        assert!(est.params[j].identifiable && !est.params[j].held);
    }
    assert!(est.residual_rms < 1e-10);
    assert!(est.paper_err_rms.is_none());
    // The regression per coordinate is c(p) exactly.
    let k = 2 * n + 1;
    let mut c = vec![0.0; 2 * k];
    model.generalized_params(&t, &mut c);
    for (g, w) in est.generalized_params.iter().zip(&c) {
        assert!((g - w).abs() < 1e-9);
    }
}

/// `|got − true| ≤ 3σ` for each listed parameter.
fn within_3_sigma(est: &Estimate, truth: &[(&str, f64)]) {
    for &(name, w) in truth {
        let g = value(est, name);
        let s = std_of(est, name);
        assert!(s > 0.0 && s.is_finite());
        let d = if name.starts_with("th") {
            wrap_angle(g - w)
        } else {
            g - w
        };
        assert!(d.abs() <= 3.0 * s, "{name}: got {g}, true {w}, std {s:e}");
    }
}

#[test]
fn line_noisy_within_three_sigma() {
    let n = 3;
    let t = truth(n, -1.8, 1.0);
    // Gauge held at the truth, so every free parameter has a true value.
    let model = PlanarArm::new(n, Kind::Line, nominal(&t, n, false));
    let mut o = SimOptions::new(400, 11);
    o.track = 30e-6;
    let poses = simulate(&model, &t, o);
    for refine in [false, true] {
        let est = calibrate(
            &model,
            &model.spec_params(),
            &poses,
            CalibrateOptions {
                refine,
                ..Default::default()
            },
        )
        .unwrap();
        let names = ["a2", "th2", "a3", "th3", "b1", "b2"];
        let want: Vec<(&str, f64)> = names.iter().map(|&nm| (nm, t[model.index(nm)])).collect();
        within_3_sigma(&est, &want);
        assert_eq!(est.rank, 2 * n + 1, "noisy data excites every direction");
        let e = est.paper_err_rms.unwrap();
        assert!(e > 20e-6 && e < 40e-6, "paper err_rms {e:e}");
        assert!(est.residual_rms > 20e-6 && est.residual_rms < 40e-6);
        assert!(est.warnings.is_empty(), "{:?}", est.warnings);
    }
}

#[test]
fn point_and_measured_noisy_within_three_sigma() {
    let n = 3;
    let t = truth(n, 0.35, 0.25);
    let model = PlanarArm::new(n, Kind::Point, nominal(&t, n, false));
    let mut o = SimOptions::new(300, 12);
    o.track = 20e-6;
    let poses = simulate(&model, &t, o);
    let est = calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions::default(),
    )
    .unwrap();
    let names = ["a2", "th2", "a3", "th3", "px", "py"];
    let want: Vec<(&str, f64)> = names.iter().map(|&nm| (nm, t[model.index(nm)])).collect();
    within_3_sigma(&est, &want);

    let t = truth(n, 0.1, -0.05);
    let model = PlanarArm::new(n, Kind::Measured, nominal(&t, n, true));
    let mut o = SimOptions::new(200, 13);
    o.measure = 50e-6;
    let poses = simulate(&model, &t, o);
    for refine in [false, true] {
        let est = calibrate(
            &model,
            &model.spec_params(),
            &poses,
            CalibrateOptions {
                refine,
                ..Default::default()
            },
        )
        .unwrap();
        let names = ["a1", "th1", "a2", "th2", "a3", "th3", "bx", "by"];
        let want: Vec<(&str, f64)> = names.iter().map(|&nm| (nm, t[model.index(nm)])).collect();
        within_3_sigma(&est, &want);
    }
}

#[test]
fn reported_std_matches_the_scatter() {
    // 40 replicates: the empirical std of th2 against the mean reported std.
    let n = 2;
    let t = truth(n, -1.8, 1.0);
    let model = PlanarArm::new(n, Kind::Line, nominal(&t, n, false));
    let (mut sum, mut sum2, mut reported) = (0.0, 0.0, 0.0);
    let reps = 40;
    for r in 0..reps {
        let mut o = SimOptions::new(100, 1000 + r);
        o.track = 50e-6;
        let poses = simulate(&model, &t, o);
        let est = calibrate(
            &model,
            &model.spec_params(),
            &poses,
            CalibrateOptions::default(),
        )
        .unwrap();
        let d = value(&est, "th2") - t[3];
        sum += d;
        sum2 += d * d;
        reported += std_of(&est, "th2");
    }
    let k = reps as f64;
    let emp = ((sum2 - sum * sum / k) / (k - 1.0)).sqrt();
    let rep = reported / k;
    let ratio = emp / rep;
    assert!(
        ratio > 0.7 && ratio < 1.4,
        "empirical {emp:e} vs reported {rep:e}"
    );
}

#[test]
fn far_nominals_still_converge() {
    // Angles far from the truth: the fit must still find the global minimum (restarts).
    let n = 3;
    let t = truth(n, -1.8, 1.0);
    let mut nom = nominal(&t, n, true);
    nom[3] += 2.6; // th2
    nom[5] -= 2.0; // th3
    nom[6] = 1.0; // b1 with the wrong sign
    let model = PlanarArm::new(n, Kind::Line, nom);
    let poses = simulate(&model, &t, SimOptions::new(50, 21));
    let est = calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions::default(),
    )
    .unwrap();
    check_combos(
        &line_combos(&est_by_name(&est), n),
        &line_combos(&by_name(&model, &t), n),
        1e-9,
    );
    for p in &est.params {
        if p.name.starts_with("th") {
            assert!(p.value > -std::f64::consts::PI && p.value <= std::f64::consts::PI);
        }
    }
}
