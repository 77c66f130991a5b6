//! Standard normal draws from the trainer's generator (ChaCha8): one at a time
//! (`standard_normal`, `libm` per draw) against a batch (`standard_normals`, eight lanes at a
//! time), the same values either way, in the same run.
//!
//! - `normals/*/2048`: one DCP update's proposal noise (batch 64 × T = 16 × 2 actions).
//! - `normals/*/32`: one state's proposals, as DCP draws them.
//! - `normals/*/2`: one exploration step of a 2-action policy.
//! - `uniforms/4096`: the generator alone, the 4,096 words 2,048 draws take.
//!
//! `cargo bench -p policy-core --bench normal`; figures in docs/performance.md.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use policy_core::normal::{standard_normal, standard_normals};
use rand_chacha::ChaCha8Rng;
use rand_core::{Rng, SeedableRng};

fn normals(c: &mut Criterion) {
    let mut group = c.benchmark_group("normals");
    group
        .measurement_time(Duration::from_secs(3))
        .sample_size(50);
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    let mut out = vec![0.0f32; 2048];
    for n in [2usize, 32, 2048] {
        group.throughput(Throughput::Elements(n as u64));
        group.bench_with_input(BenchmarkId::new("scalar", n), &n, |b, &n| {
            b.iter(|| {
                for z in &mut out[..n] {
                    *z = standard_normal(&mut rng);
                }
                black_box(&out);
            })
        });
        group.bench_with_input(BenchmarkId::new("batch", n), &n, |b, &n| {
            b.iter(|| {
                standard_normals(&mut rng, &mut out[..n]);
                black_box(&out);
            })
        });
    }
    group.finish();

    let mut words = vec![0u32; 4096];
    c.bench_function("uniforms/4096", |b| {
        b.iter(|| {
            words.iter_mut().for_each(|w| *w = rng.next_u32());
            black_box(&words);
        })
    });
}

criterion_group!(benches, normals);
criterion_main!(benches);
