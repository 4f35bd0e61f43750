//! `basis(q)` of the PUMA 560 plane model (K = 195): the derived straight-line code against the
//! run-time engine's interpreted evaluation of the same `Φ̃`, per pose.
//!
//! Run: `cargo bench -p lincal-models --bench basis`. Figures are in `BENCHMARKS.md`.

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lincal_core::model::CalibModel;
use lincal_core::symbolic::SymbolicModel;
use lincal_models::Puma560Plane;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const POSES: usize = 64;

fn poses() -> Vec<[f64; 6]> {
    let mut rng = ChaCha8Rng::seed_from_u64(560);
    (0..POSES)
        .map(|_| std::array::from_fn(|_| rng.gen_range(-3.0..3.0)))
        .collect()
}

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("specs/puma560_plane.yaml");
    let spec = lincal_core::spec::from_yaml_file(&path).unwrap();
    let runtime = SymbolicModel::from_spec(&spec).unwrap();
    let qs = poses();
    let mut group = c.benchmark_group("puma560_plane_basis");
    group.throughput(Throughput::Elements(POSES as u64));
    group.bench_function("generated", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for q in &qs {
                let phi = Puma560Plane::basis(black_box(q));
                acc += phi[black_box(7)];
            }
            acc
        });
    });
    let mut out = vec![0.0; runtime.basis_size()];
    group.bench_function("runtime", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for q in &qs {
                runtime.basis(black_box(q), &mut out);
                acc += out[black_box(7)];
            }
            acc
        });
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
