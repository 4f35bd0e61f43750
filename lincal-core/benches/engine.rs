//! Symbolic engine speed: expansion + exact column reduction + identifiability for the
//! PUMA 560 (standard DH, every a, d and home offset unknown) on an unknown plane and on an
//! unknown sphere. Run with `cargo bench -p lincal-core --bench engine`.
use criterion::{criterion_group, criterion_main, Criterion};
use lincal_core::symbolic::SymbolicModel;
use std::path::Path;

fn spec(name: &str) -> lincal_core::spec::Spec {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../lincal-models/specs")
        .join(name);
    lincal_core::spec::from_yaml_file(&path).expect("spec loads")
}

fn engine(c: &mut Criterion) {
    let mut g = c.benchmark_group("symbolic");
    g.sample_size(10);
    for name in [
        "adept_one.yaml",
        "puma560_plane.yaml",
        "puma560_sphere.yaml",
    ] {
        let s = spec(name);
        g.bench_function(name.trim_end_matches(".yaml"), |b| {
            b.iter(|| SymbolicModel::from_spec(&s).expect("model"));
        });
    }
    g.finish();
}

criterion_group!(benches, engine);
criterion_main!(benches);
