//! Streaming: memory O(K²) whatever the number of poses; a million poses calibrate.

use super::models::{Kind, PlanarArm};
use lincal_core::calibrate::{calibrate, CalibrateOptions};
use lincal_core::data::Poses;
use lincal_core::numeric::linalg::StreamingQr;
use lincal_core::numeric::wrap_angle;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

#[test]
fn streaming_qr_reproduces_the_gram_matrix() {
    let cols = 6;
    let mut qr = StreamingQr::new(cols);
    let mut gram = vec![0.0; cols * cols];
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let rows = 100_000;
    for _ in 0..rows {
        let row: Vec<f64> = (0..cols)
            .map(|c| rng.gen_range(-1.0..1.0) * (c + 1) as f64)
            .collect();
        for a in 0..cols {
            for b in 0..cols {
                gram[a * cols + b] += row[a] * row[b];
            }
        }
        qr.push_row(&row);
    }
    assert_eq!(qr.rows(), rows);
    let r = qr.finish();
    let rtr = r.transpose() * &r;
    for a in 0..cols {
        for b in 0..cols {
            let g = gram[a * cols + b];
            assert!((rtr[(a, b)] - g).abs() < 1e-9 * gram[a * cols + a].max(gram[b * cols + b]));
        }
        for b in 0..a {
            assert_eq!(r[(a, b)], 0.0, "R is upper triangular");
        }
    }
    // Fewer rows than columns: zero rows at the bottom.
    let mut small = StreamingQr::new(4);
    small.push_row(&[1.0, 2.0, 3.0, 4.0]);
    let r = small.finish();
    assert_eq!(r.nrows(), 4);
    assert!(r.rows(1, 3).iter().all(|&v| v.abs() < 1e-12));
}

#[test]
fn a_million_poses() {
    // Planar 2R on a line, poses placed analytically: q1 solves the line equation.
    let (a1, th1, a2, th2, b1, b2) = (0.375, 0.01, 0.425, 0.0446, -1.79, -0.56);
    let truth = vec![a1, th1, a2, th2, b1, b2];
    let model = PlanarArm::new(2, Kind::Line, vec![0.375, 0.0, 0.4, 0.0, -1.5, -0.7]);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let n = 1_000_000;
    let mut poses = Poses {
        q: lincal_core::data::Rows::new(2),
        constraint: lincal_core::data::PoseColumn::labels_from(std::iter::repeat_n(0, n)),
        line: lincal_core::data::PoseColumn::counting(),
        measured: None,
        files: Default::default(),
    };
    let bn = (b1 * b1 + b2 * b2_f(b2)).sqrt();
    let beta = b2.atan2(b1);
    while poses.q.len() < n {
        let q2: f64 = rng.gen_range(-2.5..2.5);
        // tip = e^{i(q1−th1)}·w, w = a1 + a2 e^{i(q2−th2)}; b·x = |b||w| cos(q1 − th1 + ∠w − β).
        let (wx, wy) = (a1 + a2 * (q2 - th2).cos(), a2 * (q2 - th2).sin());
        let wn = wx.hypot(wy);
        let c = -1.0 / (bn * wn);
        if c.abs() >= 1.0 {
            continue;
        }
        let sign = if rng.gen::<bool>() { 1.0 } else { -1.0 };
        let q1 = wrap_angle(sign * c.acos() + th1 - wy.atan2(wx) + beta);
        poses.q.push(&[q1, q2]);
        poses.line.push(poses.q.len() + 1);
    }
    let t = std::time::Instant::now();
    let est = calibrate(
        &model,
        &model.spec_params(),
        &poses,
        CalibrateOptions::default(),
    )
    .unwrap();
    eprintln!("a million poses: {:?}", t.elapsed());
    assert_eq!(est.poses, n);
    assert!((est.params[2].value / est.params[0].value - a2 / a1).abs() < 1e-9);
    assert!(wrap_angle(est.params[3].value - th2).abs() < 1e-9);
    let _ = truth;
}

fn b2_f(b2: f64) -> f64 {
    b2
}
