//! Every derived model against the run-time engine built from the same spec: `basis(q)` per
//! pose, `generalized_params(p)` and `jacobian(p)` per parameter vector (issue 48's targets:
//! the derived form at least 5× faster than the run-time model).
//!
//! Run: `cargo bench -p lincal-models --bench models`; figures in `BENCHMARKS.md`. With
//! `BENCH_MODELS=kuka` only the models whose spec file holds that text (for profiling).

use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use lincal_core::model::CalibModel;
use lincal_core::symbolic::SymbolicModel;
use lincal_models::*;

/// Median time per call of `f` over `rounds` rounds of `reps` calls.
fn time(mut f: impl FnMut(), reps: usize) -> Duration {
    let mut v: Vec<Duration> = (0..15)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..reps {
                f();
            }
            t.elapsed() / reps as u32
        })
        .collect();
    v.sort();
    v[v.len() / 2]
}

fn fmt(d: Duration) -> String {
    let ns = d.as_nanos();
    if ns < 10_000 {
        format!("{ns} ns")
    } else if ns < 10_000_000 {
        format!("{:.1} µs", ns as f64 / 1e3)
    } else {
        format!("{:.1} ms", ns as f64 / 1e6)
    }
}

fn bench(derived: &dyn CalibModel, file: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("specs")
        .join(file);
    let spec = lincal_core::spec::from_yaml_file(&path).unwrap();
    let rt = SymbolicModel::from_spec(&spec).unwrap();
    let (k, e, np) = (rt.basis_size(), rt.equation_count(), rt.param_count());
    let q: Vec<f64> = (0..rt.joint_count())
        .map(|i| 0.3 + 0.1 * i as f64)
        .collect();
    let p: Vec<f64> = (0..np).map(|j| rt.param_nominal(j) + 0.01).collect();
    let mut phi = vec![0.0; k];
    let mut c = vec![0.0; e * k];
    let mut jac = vec![0.0; e * k * np];
    let reps = (200_000 / k).max(1);
    let b_d = time(|| derived.basis(black_box(&q), &mut phi), reps);
    let b_r = time(|| rt.basis(black_box(&q), &mut phi), reps);
    let reps_c = (20_000 / (e * k)).max(1);
    let c_d = time(|| derived.generalized_params(black_box(&p), &mut c), reps_c);
    let c_r = time(|| rt.generalized_params(black_box(&p), &mut c), reps_c);
    let reps_j = (2_000 / (e * k)).max(1);
    let j_d = time(|| derived.jacobian(black_box(&p), &mut jac), reps_j);
    let j_r = time(|| rt.jacobian(black_box(&p), &mut jac), reps_j);
    let r = |a: Duration, b: Duration| b.as_secs_f64() / a.as_secs_f64();
    println!(
        "| {} | {k} | {} | {} | {:.1}× | {} | {} | {:.1}× | {} | {} | {:.1}× |",
        spec.name,
        fmt(b_d),
        fmt(b_r),
        r(b_d, b_r),
        fmt(c_d),
        fmt(c_r),
        r(c_d, c_r),
        fmt(j_d),
        fmt(j_r),
        r(j_d, j_r)
    );
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    println!("| model | K | basis derived | run time | speed-up | c(p) derived | run time | speed-up | ∂c/∂p derived | run time | speed-up |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let models: [(&dyn CalibModel, &str); 18] = [
        (&AdeptOne, "adept_one.yaml"),
        (&AdeptOneScara, "adept_one_scara.yaml"),
        (&Planar3Line, "planar3_line.yaml"),
        (&Planar3Point, "planar3_point.yaml"),
        (&ScaraPlane, "scara_plane.yaml"),
        (&Elbow3Line, "elbow3_line.yaml"),
        (&AbbIrb120BallBar, "abb_irb120_ballbar.yaml"),
        (&Ur5Tracker, "ur5_tracker.yaml"),
        (&Puma560Plane, "puma560_plane.yaml"),
        (&Puma560MdhPlane, "puma560_mdh_plane.yaml"),
        (&Puma560Sphere, "puma560_sphere.yaml"),
        (&Puma560PoseFrames, "puma560_pose_frames.yaml"),
        (&StanfordArmTracker, "stanford_arm_tracker.yaml"),
        (&Ur10Tracker, "ur10_tracker.yaml"),
        (&Puma560PoseTracker, "puma560_pose_tracker.yaml"),
        (&KukaIiwa14Point, "kuka_iiwa14_point.yaml"),
        (&FrankaPandaSockets, "franka_panda_sockets.yaml"),
        (&Arm7AllUnknownPoint, "arm7_all_unknown_point.yaml"),
    ];
    let only = std::env::var("BENCH_MODELS").unwrap_or_default();
    for (m, file) in models {
        if file.contains(only.as_str()) {
            bench(m, file);
        }
    }
}
