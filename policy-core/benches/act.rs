//! `act` for the paper's actor sizes, and the two costs it is made of.
//!
//! - `act/tanh/*`: the real thing, the compiled `Policy::act` with tanh hidden layers.
//! - `model/{tanh,relu}/*`: the same blob run by the runtime `Model::act` straight from its bytes
//!   (no compiled shape; the aligned payload is read as `f32` words), in the same run.
//! - `model-unaligned/*`: the same blob one byte off alignment, every weight decoded with
//!   `f32::from_le_bytes`: the cost of the other read path.
//! - `act/relu/*`: the same network with ReLU, whose activation costs next to nothing, so it
//!   measures the normaliser, the multiply-adds and the output scaling alone.
//! - `tanhf/libm/*`: `libm::tanhf` on as many values as one `act` call evaluates (every hidden
//!   unit plus every action): the contract's tanh, one call at a time.
//! - `tanhf/policy_core/*`: the same values through `policy_core::tanh::tanh_in_place`, the
//!   bit-identical branch-free version `act` uses for hidden layers on SIMD targets.
//! - `mac_peak`: a 64×64 layer from L1, repeated: the best multiply-add rate this kernel reaches.
//!
//! `cargo bench -p policy-core --bench act`; numbers and the floor are in the README.

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use policy_core::model::{Model, Scratch};
use policy_core::{blob, ActionBounds, Activation, Dense, Encoding, Policy};

/// SplitMix64 in `[-1, 1)`: the benchmark's weights only need to be non-trivial and fixed.
struct Uniform(u64);

impl Uniform {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 * (1.0 / 8_388_608.0) - 1.0
    }
}

fn fill<const I: usize, const O: usize>(d: &mut Dense<I, O>, rng: &mut Uniform) {
    let scale = 1.0 / (I as f32).sqrt();
    d.w.iter_mut()
        .chain(d.b.iter_mut())
        .for_each(|v| *v = scale * rng.next());
}

/// A navigation-like actor with DDPG-scale random weights, boxed (the 6×64 is 85 KB).
fn actor<const H: usize, const L: usize>(activation: Activation) -> Box<Policy<2, H, L, 2>> {
    let mut rng = Uniform(H as u64);
    let mut p = Box::new(Policy::<2, H, L, 2>::ZERO);
    p.normalizer.mean.fill(0.0);
    p.normalizer.inv_std.fill(1.0 / 3.46);
    p.normalizer.clip = 5.0;
    p.bounds = ActionBounds::symmetric(0.25);
    fill(&mut p.input, &mut rng);
    p.trunk.hidden.iter_mut().for_each(|d| fill(d, &mut rng));
    fill(&mut p.trunk.output, &mut rng);
    p.trunk.activation = activation;
    p
}

/// Multiply-adds and tanh evaluations of one `act` call.
fn costs(h: usize, l: usize) -> (u64, u64) {
    let (s, a) = (2, 2);
    ((s * h + l * h * h + h * a) as u64, ((l + 1) * h + a) as u64)
}

fn bench_shape<const H: usize, const L: usize>(c: &mut Criterion, name: &str) {
    let (macs, tanhs) = costs(H, L);
    let observations: Vec<[f32; 2]> = {
        let mut rng = Uniform(7);
        (0..64)
            .map(|_| [6.0 * rng.next(), 6.0 * rng.next()])
            .collect()
    };
    for activation in [Activation::Tanh, Activation::Relu] {
        let p = actor::<H, L>(activation);
        let mut group = c.benchmark_group(format!("act/{activation}"));
        group.throughput(Throughput::Elements(macs));
        let mut i = 0;
        group.bench_function(name, |b| {
            b.iter(|| {
                i = (i + 1) % observations.len();
                black_box(&*p).act(black_box(&observations[i]))
            })
        });
        group.finish();
        // The same network from its blob bytes, through the runtime.
        let mut bytes = vec![0u8; blob::blob_len(&*p, "bench").expect("length")];
        blob::write_into(&*p, "bench", &mut bytes).expect("blob");
        let model = Model::from_blob(&bytes).expect("model");
        let mut scratch = Scratch::<64>::new();
        let mut group = c.benchmark_group(format!("model/{activation}"));
        group.throughput(Throughput::Elements(macs));
        let mut i = 0;
        group.bench_function(name, |b| {
            b.iter(|| {
                i = (i + 1) % observations.len();
                let mut a = [0.0f32; 2];
                let _ = black_box(&model).act(black_box(&observations[i]), &mut scratch, &mut a);
                a
            })
        });
        group.finish();
        // The same network with quantised weights (ReLU only: the per-weight cost is the point;
        // with tanh the activation dominates).
        if activation == Activation::Relu {
            for encoding in [Encoding::F16, Encoding::Int8] {
                let values: Vec<f32> = model.values().collect();
                let spec = blob::Spec {
                    kind: policy_core::ModelKind::Actor,
                    encoding,
                    shape: model.header().shape,
                    activation,
                    label: "bench",
                };
                let mut q = vec![0u8; blob::encoded_len(&spec).expect("length")];
                blob::write(&spec, &mut |sink| sink(&values), &mut q).expect("blob");
                let quantised = Model::from_blob(&q).expect("model");
                let mut group = c.benchmark_group(format!("model-{encoding}/{activation}"));
                group.throughput(Throughput::Elements(macs));
                group.bench_function(name, |b| {
                    b.iter(|| {
                        i = (i + 1) % observations.len();
                        let mut a = [0.0f32; 2];
                        let _ = black_box(&quantised).act(
                            black_box(&observations[i]),
                            &mut scratch,
                            &mut a,
                        );
                        a
                    })
                });
                group.finish();
            }
        }
        // The same blob one byte off a 4-byte boundary: the payload cannot be viewed as `f32`
        // words, so every weight is decoded with `f32::from_le_bytes` (the other read path).
        let mut shifted = vec![0u8; bytes.len() + 1];
        shifted[1..].copy_from_slice(&bytes);
        let unaligned = Model::from_blob(&shifted[1..]).expect("model");
        let mut group = c.benchmark_group(format!("model-unaligned/{activation}"));
        group.throughput(Throughput::Elements(macs));
        group.bench_function(name, |b| {
            b.iter(|| {
                i = (i + 1) % observations.len();
                let mut a = [0.0f32; 2];
                let _ =
                    black_box(&unaligned).act(black_box(&observations[i]), &mut scratch, &mut a);
                a
            })
        });
        group.finish();
    }
    // As many tanhf calls as one act, on values like a hidden layer's pre-activations.
    let mut rng = Uniform(11);
    let inputs: Vec<f32> = (0..tanhs).map(|_| 2.0 * rng.next()).collect();
    c.bench_function(&format!("tanhf/libm/{name} ({tanhs} calls)"), |b| {
        b.iter(|| {
            black_box(&inputs)
                .iter()
                .map(|&x| libm::tanhf(x))
                .fold(0.0f32, |s, t| s + t)
        })
    });
    // The same values through the branch-free, bit-identical version `act` uses.
    let mut layer = inputs.clone();
    c.bench_function(&format!("tanhf/policy_core/{name} ({tanhs} values)"), |b| {
        b.iter(|| {
            layer.copy_from_slice(black_box(&inputs));
            policy_core::tanh::tanh_in_place(&mut layer);
            layer[0]
        })
    });
}

fn mac_peak(c: &mut Criterion) {
    let mut rng = Uniform(3);
    let mut layer = Box::new(Dense::<64, 64>::ZERO);
    fill(&mut layer, &mut rng);
    let x: Vec<f32> = (0..64).map(|_| rng.next()).collect();
    let mut group = c.benchmark_group("mac_peak");
    group.throughput(Throughput::Elements(64 * 64 * 16));
    group.bench_function("64x64 layer x16", |b| {
        b.iter(|| {
            let mut y = layer.b;
            for _ in 0..16 {
                black_box(&*layer).accumulate(black_box(&x), &mut y);
            }
            y
        })
    });
    group.finish();
}

fn benches(c: &mut Criterion) {
    let p = actor::<48, 3>(Activation::Tanh);
    let blob_len = blob::blob_len(&*p, "nav dcp 4x48 seed 0").expect("blob length");
    eprintln!(
        "sizes: 4x48 blob {blob_len} bytes (label of 19 bytes), size_of::<Policy<2, 48, 3, 2>>() = {} bytes",
        std::mem::size_of::<Policy<2, 48, 3, 2>>()
    );
    for (name, h, l) in [("2x32", 32, 1), ("4x48", 48, 3), ("6x64", 64, 5)] {
        let (macs, tanhs) = costs(h, l);
        eprintln!("costs: {name}: {macs} multiply-adds, {tanhs} tanhf per act");
    }
    bench_shape::<32, 1>(c, "2x32");
    bench_shape::<48, 3>(c, "4x48");
    bench_shape::<64, 5>(c, "6x64");
    mac_peak(c);
}

criterion_group! {
    name = act;
    // Short runs: the numbers are stable to a few percent at 2 s per benchmark.
    config = Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    targets = benches
}
criterion_main!(act);
