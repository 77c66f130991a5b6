//! Speed of the network machinery on the shapes of a training update (4×48 ReLU, batch 64): single
//! passes, and the network work of whole DDPG / DCP updates without replay, normalisation or
//! bookkeeping (the full updates are in `benches/update.rs`).
//!
//! `cargo bench -p host-trainer --bench nn`

use criterion::{criterion_group, criterion_main, Criterion};
use firmware_sim::seed::{training_stream, uniform_in};
use host_trainer::nn::adam::Adam;
use host_trainer::nn::net::{soft_update, Matrix, Net, NetConfig, Output, Tape};
use policy_core::Activation;
use std::hint::black_box;

fn net(inputs: usize, outputs: usize, output: Output, dropout: f32) -> Net {
    net_with(Activation::Relu, inputs, outputs, output, dropout)
}

/// ReLU is the training default; the tanh critic shows what the activation costs.
fn net_with(
    activation: Activation,
    inputs: usize,
    outputs: usize,
    output: Output,
    dropout: f32,
) -> Net {
    let config = NetConfig {
        inputs,
        width: 48,
        depth: 4,
        outputs,
        activation,
        output,
        dropout,
    };
    Net::new(config, &mut training_stream(1, "bench"))
}

fn batch(rows: usize, cols: usize) -> Matrix {
    let mut rng = training_stream(2, "bench");
    Matrix::from_vec(
        rows,
        cols,
        (0..rows * cols)
            .map(|_| uniform_in(&mut rng, -1.0, 1.0))
            .collect(),
    )
}

fn layers(c: &mut Criterion) {
    let critic = net(4, 1, Output::Linear, 0.0);
    let actor = net(2, 2, Output::Tanh, 0.5);
    let (x64, x1088) = (batch(64, 4), batch(64 * 17, 4));
    let (g64, obs) = (batch(64, 1), batch(64, 2));
    let mut tape = Tape::default();
    let mut grads = critic.zero_grads();
    let mut dx = Matrix::default();
    c.bench_function("critic 4x48 forward, 64 rows", |b| {
        b.iter(|| black_box(critic.forward(&x64, &mut tape, None).data[0]))
    });
    let mut group = c.benchmark_group("critic 4x48 forward, 64x17 rows (DCP T=16 scoring)");
    // Multiply-adds per row: 4x48 + 3 x 48x48 + 48x1.
    group.throughput(criterion::Throughput::Elements(64 * 17 * 7_152));
    group.bench_function("relu", |b| {
        b.iter(|| black_box(critic.forward(&x1088, &mut tape, None).data[0]))
    });
    group.finish();
    let tanh_critic = net_with(Activation::Tanh, 4, 1, Output::Linear, 0.0);
    c.bench_function("tanh critic 4x48 forward, 64x17 rows", |b| {
        b.iter(|| black_box(tanh_critic.forward(&x1088, &mut tape, None).data[0]))
    });
    c.bench_function("critic 4x48 forward+backward, 64 rows", |b| {
        b.iter(|| {
            critic.forward(&x64, &mut tape, None);
            critic.backward_into(&mut tape, &g64, &mut grads, &mut dx);
            black_box(dx.data[0])
        })
    });
    c.bench_function("critic 4x48 forward + dQ/dinput only, 64 rows", |b| {
        b.iter(|| {
            critic.forward(&x64, &mut tape, None);
            critic.input_grads_into(&mut tape, &g64, &mut dx);
            black_box(dx.data[0])
        })
    });
    let mut rng = training_stream(3, "dropout");
    let mut agrads = actor.zero_grads();
    let ga = batch(64, 2);
    c.bench_function("actor 4x48 forward+backward, dropout 0.5, 64 rows", |b| {
        b.iter(|| {
            actor.forward(&obs, &mut tape, Some(&mut rng));
            actor.backward_into(&mut tape, &ga, &mut agrads, &mut dx);
            black_box(dx.data[0])
        })
    });
    let mut adam = Adam::new(&critic, 1.0 / 4096.0, 1e-4);
    let mut trained = critic.clone();
    let mut target = critic.clone();
    c.bench_function("critic 4x48 Adam step + soft update", |b| {
        b.iter(|| {
            adam.step(&mut trained, &grads);
            soft_update(&mut target, &trained, 0.005);
            black_box(target.layers[0].w[0])
        })
    });
    c.bench_function("forward_one 4x48 actor", |b| {
        let mut out = [0.0; 2];
        b.iter(|| {
            actor.forward_one(black_box(&[0.3, -0.7]), &mut out);
            black_box(out[0])
        })
    });
}

/// The networks of one agent and the buffers of its updates.
struct Nets {
    actor: Net,
    critic: Net,
    actor_target: Net,
    critic_target: Net,
    actor_opt: Adam,
    critic_opt: Adam,
    tapes: [Tape; 2],
    grads: [host_trainer::nn::net::Grads; 2],
    dx: Matrix,
}

impl Nets {
    fn new() -> Self {
        let actor = net(2, 2, Output::Tanh, 0.0);
        let critic = net(4, 1, Output::Linear, 0.0);
        Nets {
            actor_opt: Adam::new(&actor, 1.0 / 4096.0, 1e-4),
            critic_opt: Adam::new(&critic, 1.0 / 4096.0, 1e-4),
            grads: [actor.zero_grads(), critic.zero_grads()],
            actor_target: actor.clone(),
            critic_target: critic.clone(),
            actor,
            critic,
            tapes: [Tape::default(), Tape::default()],
            dx: Matrix::default(),
        }
    }

    /// Bellman target pass, then a critic step (forward, backward, Adam).
    fn critic_step(&mut self, obs: &Matrix, sa: &Matrix, g: &Matrix) {
        let [ta, tc] = &mut self.tapes;
        self.actor_target.forward(obs, ta, None);
        black_box(self.critic_target.forward(sa, tc, None).data[0]);
        self.grads[1].zero();
        self.critic.forward(sa, tc, None);
        self.critic
            .backward_into(tc, g, &mut self.grads[1], &mut self.dx);
        self.critic_opt.step(&mut self.critic, &self.grads[1]);
    }

    /// Actor step: forward, the critic pass `scored` (DDPG: dQ/da on 64 rows; DCP: Q of the
    /// 64 × (T + 1) proposals), actor backward and Adam, then both soft updates.
    fn actor_step(&mut self, obs: &Matrix, scored: &Matrix, g: &Matrix, ddpg: bool) {
        let [ta, tc] = &mut self.tapes;
        self.grads[0].zero();
        self.actor.forward(obs, ta, None);
        self.critic.forward(scored, tc, None);
        if ddpg {
            let ones = Matrix::from_vec(scored.rows, 1, vec![1.0; scored.rows]);
            self.critic.input_grads_into(tc, &ones, &mut self.dx);
        }
        self.actor
            .backward_into(ta, g, &mut self.grads[0], &mut self.dx);
        self.actor_opt.step(&mut self.actor, &self.grads[0]);
        soft_update(&mut self.critic_target, &self.critic, 0.005);
        soft_update(&mut self.actor_target, &self.actor, 0.005);
    }
}

fn update_shaped(c: &mut Criterion) {
    let mut nets = Nets::new();
    let (obs, sa, gq, ga) = (batch(64, 2), batch(64, 4), batch(64, 1), batch(64, 2));
    c.bench_function("DDPG-shaped update, networks only", |b| {
        b.iter(|| {
            nets.critic_step(&obs, &sa, &gq);
            nets.actor_step(&obs, &sa, &ga, true);
        })
    });
    for t in [1, 4, 16] {
        let scored = batch(64 * (t + 1), 4);
        c.bench_function(&format!("DCP-shaped update T={t}, networks only"), |b| {
            b.iter(|| {
                nets.critic_step(&obs, &sa, &gq);
                nets.actor_step(&obs, &scored, &ga, false);
            })
        });
    }
}

/// The build's multiply-add peak, the yardstick for the kernels: 12 independent chains of
/// 8-lane multiply-adds (fused where the build has FMA, as in the kernels) on registers only.
/// Criterion's throughput line gives multiply-adds per second.
fn mac_peak(c: &mut Criterion) {
    const STEPS: usize = 1_000;
    let mut group = c.benchmark_group("peak");
    group.throughput(criterion::Throughput::Elements((STEPS * 12 * 8) as u64));
    group.bench_function("register multiply-adds, 12 x 8 lanes", |b| {
        b.iter(|| {
            let (x, y) = (black_box(0.999_f32), black_box(1e-4_f32));
            // Distinct starting values, so no two chains can be merged by the compiler.
            let mut acc: [[f32; 8]; 12] =
                std::array::from_fn(|i| std::array::from_fn(|j| black_box((i * 8 + j) as f32)));
            for _ in 0..STEPS {
                for chain in acc.iter_mut() {
                    for lane in chain.iter_mut() {
                        #[cfg(target_feature = "fma")]
                        {
                            *lane = lane.mul_add(x, y);
                        }
                        #[cfg(not(target_feature = "fma"))]
                        {
                            *lane = *lane * x + y;
                        }
                    }
                }
            }
            black_box(acc)
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).warm_up_time(std::time::Duration::from_millis(500)).measurement_time(std::time::Duration::from_secs(2));
    targets = mac_peak, layers, update_shaped
}
criterion_main!(benches);
