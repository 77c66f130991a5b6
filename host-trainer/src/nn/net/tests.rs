//! Gradient checks against finite differences, dropout, and batch/single agreement.

use super::*;
use firmware_sim::seed::{training_stream, uniform_in};

fn config(activation: Activation, output: Output, dropout: f32) -> NetConfig {
    NetConfig {
        inputs: 3,
        width: 6,
        depth: 3,
        outputs: 2,
        activation,
        output,
        dropout,
    }
}

/// A network with weights large enough that every layer matters (DDPG's ±3e-3 output layer
/// would make the hidden layers' gradients tiny and the check weak).
fn spread_net(config: NetConfig, seed: u64) -> Net {
    let mut rng = training_stream(seed, "gradcheck");
    let mut net = Net::new(config, &mut rng);
    net.layers
        .iter_mut()
        .flat_map(Layer::params_mut)
        .for_each(|p| *p = uniform_in(&mut rng, -0.9, 0.9));
    net
}

fn random_matrix(rows: usize, cols: usize, scale: f32, seed: u64) -> Matrix {
    let mut rng = training_stream(seed, "matrix");
    Matrix::from_vec(
        rows,
        cols,
        (0..rows * cols)
            .map(|_| uniform_in(&mut rng, -scale, scale))
            .collect(),
    )
}

/// `L = Σ c[r, o] y[r, o]` in f64, with the dropout mask drawn from a fresh `dropout_seed` stream
/// (so every evaluation of a perturbed network sees the same mask).
fn loss(net: &Net, x: &Matrix, c: &Matrix, dropout_seed: Option<u64>) -> f64 {
    let mut tape = Tape::default();
    let mut rng = dropout_seed.map(|s| training_stream(s, "dropout"));
    let y = net.forward(x, &mut tape, rng.as_mut());
    y.data
        .iter()
        .zip(&c.data)
        .map(|(&y, &c)| f64::from(y) * f64::from(c))
        .sum()
}

/// Signs of every hidden pre-activation, to detect a finite difference crossing a ReLU kink.
fn relu_pattern(net: &Net, x: &Matrix) -> Vec<bool> {
    let mut tape = Tape::default();
    net.forward(x, &mut tape, None);
    tape.record
        .hidden
        .iter()
        .flat_map(|h| h.data.iter().map(|&v| v > 0.0))
        .collect()
}

fn close(analytic: f64, numeric: f64) -> bool {
    (analytic - numeric).abs() <= 1e-3 + 1e-2 * numeric.abs()
}

/// Central differences with step `EPS` for every parameter and every input, against backward.
fn check_gradients(config: NetConfig, seed: u64, dropout_seed: Option<u64>) {
    const EPS: f32 = 3e-3;
    let net = spread_net(config, seed);
    let x = random_matrix(5, 3, 1.5, seed + 1);
    let c = random_matrix(5, 2, 1.0, seed + 2);
    let mut tape = Tape::default();
    let mut rng = dropout_seed.map(|s| training_stream(s, "dropout"));
    net.forward(&x, &mut tape, rng.as_mut());
    let mut grads = net.zero_grads();
    let dx = net.backward(&tape, &c, &mut grads);
    let base = relu_pattern(&net, &x);
    let mut checked = 0;
    for l in 0..net.layers.len() {
        let n = net.layers[l].w.len() + net.layers[l].b.len();
        for k in 0..n {
            let perturbed = |delta: f32| {
                let mut p = net.clone();
                *p.layers[l].params_mut().nth(k).expect("parameter index") += delta;
                p
            };
            let (plus, minus) = (perturbed(EPS), perturbed(-EPS));
            if relu_pattern(&plus, &x) != base || relu_pattern(&minus, &x) != base {
                continue;
            }
            let numeric = (loss(&plus, &x, &c, dropout_seed) - loss(&minus, &x, &c, dropout_seed))
                / f64::from(2.0 * EPS);
            let analytic = f64::from(*grads.layers[l].params().nth(k).expect("parameter index"));
            assert!(
                close(analytic, numeric),
                "layer {l} param {k}: backward {analytic} vs finite difference {numeric}"
            );
            checked += 1;
        }
    }
    assert!(
        checked * 10 >= net.param_count() * 9,
        "only {checked} of {} parameters checked",
        net.param_count()
    );
    for i in 0..x.data.len() {
        let mut plus = x.clone();
        let mut minus = x.clone();
        plus.data[i] += EPS;
        minus.data[i] -= EPS;
        if relu_pattern(&net, &plus) != base || relu_pattern(&net, &minus) != base {
            continue;
        }
        let numeric = (loss(&net, &plus, &c, dropout_seed) - loss(&net, &minus, &c, dropout_seed))
            / f64::from(2.0 * EPS);
        assert!(
            close(f64::from(dx.data[i]), numeric),
            "input {i}: backward {} vs finite difference {numeric}",
            dx.data[i]
        );
    }
    // The check must have had something to check.
    assert!(grads.norm() > 0.1 && dx.data.iter().any(|g| g.abs() > 0.01));
}

#[test]
fn gradients_tanh_hidden_tanh_output() {
    check_gradients(config(Activation::Tanh, Output::Tanh, 0.0), 1, None);
}

#[test]
fn gradients_tanh_hidden_linear_output() {
    check_gradients(config(Activation::Tanh, Output::Linear, 0.0), 2, None);
}

#[test]
fn gradients_relu_hidden_tanh_output() {
    check_gradients(config(Activation::Relu, Output::Tanh, 0.0), 3, None);
}

#[test]
fn gradients_relu_hidden_linear_output() {
    check_gradients(config(Activation::Relu, Output::Linear, 0.0), 4, None);
}

#[test]
fn gradients_through_a_fixed_dropout_mask() {
    check_gradients(config(Activation::Tanh, Output::Linear, 0.5), 5, Some(77));
    check_gradients(config(Activation::Relu, Output::Tanh, 0.3), 6, Some(78));
}

#[test]
fn backward_adds_into_grads() {
    let net = spread_net(config(Activation::Tanh, Output::Linear, 0.0), 7);
    let x = random_matrix(4, 3, 1.0, 8);
    let g = random_matrix(4, 2, 1.0, 9);
    let mut tape = Tape::default();
    net.forward(&x, &mut tape, None);
    let mut once = net.zero_grads();
    net.backward(&tape, &g, &mut once);
    let mut twice = net.zero_grads();
    net.backward(&tape, &g, &mut twice);
    net.backward(&tape, &g, &mut twice);
    once.scale(2.0);
    for (a, b) in once.layers.iter().zip(&twice.layers) {
        for (&a, &b) in a.params().zip(b.params()) {
            assert!(
                (a - b).abs() <= 1e-6 * (1.0 + a.abs()),
                "2 x once {a} vs twice {b}"
            );
        }
    }
    twice.zero();
    assert_eq!(twice, net.zero_grads());
}

#[test]
fn dropout_drops_and_rescales_in_training_only() {
    let mut cfg = config(Activation::Tanh, Output::Linear, 0.5);
    cfg.width = 64;
    let net = spread_net(cfg, 10);
    let x = random_matrix(32, 3, 1.0, 11);
    let mut tape = Tape::default();
    let mut rng = training_stream(12, "dropout");
    let train = net.forward(&x, &mut tape, Some(&mut rng)).clone();
    let rec = &tape.record;
    assert!(rec.dropout);
    let (mut zeros, mut total) = (0usize, 0usize);
    for ((h, m), d) in rec.hidden.iter().zip(&rec.masks).zip(&rec.dropped) {
        for ((&h, &m), &d) in h.data.iter().zip(&m.data).zip(&d.data) {
            assert!(m == 0.0 || m == 2.0, "inverted dropout factor {m}");
            assert_eq!(d, h * m);
            zeros += usize::from(m == 0.0);
            total += 1;
        }
    }
    let rate = zeros as f64 / total as f64;
    assert!((0.45..0.55).contains(&rate), "drop rate {rate}");
    // Evaluation ignores dropout: deterministic and equal to the single-sample pass.
    let eval = net.forward(&x, &mut tape, None).clone();
    assert_ne!(eval, train);
    assert_eq!(net.forward(&x, &mut tape, None), &eval);
    let mut one = [0.0; 2];
    for r in 0..x.rows {
        net.forward_one(x.row(r), &mut one);
        for (a, b) in one.iter().zip(eval.row(r)) {
            assert!(
                (a - b).abs() <= 1e-5 * (1.0 + a.abs()),
                "row {r}: {a} vs {b}"
            );
        }
    }
    // Same seed, same mask.
    let again = net
        .forward(&x, &mut tape, Some(&mut training_stream(12, "dropout")))
        .clone();
    assert_eq!(again, train);
}

#[test]
fn batch_agrees_with_forward_one_on_odd_shapes() {
    for (activation, output, width, rows) in [
        (Activation::Tanh, Output::Tanh, 48, 17),
        (Activation::Relu, Output::Linear, 33, 5),
        (Activation::Tanh, Output::Linear, 7, 1),
    ] {
        let cfg = NetConfig {
            inputs: 4,
            width,
            depth: 4,
            outputs: 3,
            activation,
            output,
            dropout: 0.0,
        };
        let net = spread_net(cfg, width as u64);
        let x = random_matrix(rows, 4, 2.0, 13);
        let mut tape = Tape::default();
        let y = net.forward(&x, &mut tape, None).clone();
        let mut one = [0.0; 3];
        for r in 0..rows {
            net.forward_one(x.row(r), &mut one);
            for (a, b) in one.iter().zip(y.row(r)) {
                assert!(
                    (a - b).abs() <= 1e-5 * (1.0 + a.abs()),
                    "row {r}: {a} vs {b}"
                );
                // Without tanh and without FMA only the summation order matters, and it is
                // policy-core's; with FMA the batched pass rounds once per multiply-add.
                if activation == Activation::Relu
                    && output == Output::Linear
                    && !cfg!(target_feature = "fma")
                {
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "row {r}: relu batch not bit-exact"
                    );
                }
            }
        }
    }
}

#[test]
fn warm_tape_is_reused_across_batch_sizes() {
    let net = spread_net(config(Activation::Relu, Output::Linear, 0.0), 14);
    let mut tape = Tape::default();
    let big = random_matrix(40, 3, 1.0, 15);
    let small = random_matrix(3, 3, 1.0, 16);
    net.forward(&big, &mut tape, None);
    let after_small = net.forward(&small, &mut tape, None).clone();
    assert_eq!((after_small.rows, after_small.cols), (3, 2));
    assert_eq!(
        after_small,
        net.forward(&small, &mut Tape::default(), None).clone()
    );
}

#[test]
fn soft_update_interpolates() {
    let cfg = config(Activation::Tanh, Output::Tanh, 0.0);
    let source = spread_net(cfg.clone(), 17);
    let mut target = spread_net(cfg, 18);
    let before = target.clone();
    soft_update(&mut target, &source, 0.25);
    for ((t, s), b) in target.layers.iter().zip(&source.layers).zip(&before.layers) {
        for ((&t, &s), &b) in t.params().zip(s.params()).zip(b.params()) {
            assert_eq!(t, 0.25 * s + 0.75 * b);
        }
    }
}

#[test]
fn a_target_weight_whose_source_is_zero_decays_to_zero_not_into_tiny_values() {
    // τ = 0.005: without the flush, the target weight sticks near 100 · 2⁻¹⁴⁹, subnormal.
    let cfg = config(Activation::Relu, Output::Tanh, 0.0);
    let mut source = spread_net(cfg.clone(), 17);
    let mut target = spread_net(cfg, 18);
    source.layers[0].w[0] = 0.0;
    target.layers[0].w[0] = 1e-3;
    for _ in 0..40_000 {
        soft_update(&mut target, &source, 0.005);
        let w = target.layers[0].w[0];
        assert!(w == 0.0 || w.abs() >= crate::nn::adam::TINY_PARAM, "{w:e}");
    }
    assert_eq!(target.layers[0].w[0], 0.0);
}

#[test]
fn ddpg_init_bounds() {
    let cfg = NetConfig {
        inputs: 4,
        width: 48,
        depth: 4,
        outputs: 1,
        activation: Activation::Relu,
        output: Output::Linear,
        dropout: 0.0,
    };
    let net = Net::new(cfg, &mut training_stream(19, "init"));
    assert!(net.is_consistent());
    for (l, layer) in net.layers.iter().enumerate() {
        let bound = if l == 4 {
            3e-3
        } else {
            1.0 / (layer.inputs as f32).sqrt()
        };
        let max = layer.params().fold(0.0f32, |m, p| m.max(p.abs()));
        assert!(
            max <= bound && max > 0.8 * bound,
            "layer {l}: max |p| {max}, bound {bound}"
        );
    }
}

/// The split inference pass gives every row the bits of one pass over the whole batch, for any
/// thread count and any number of rows (whole tiles of 6, remainders of 4 and 1, splits that
/// fall inside a tile's worth of rows), with the critic's one-output layer and a tanh actor.
#[test]
fn split_inference_is_bit_identical_to_one_pass_for_any_thread_count() {
    let shapes = [
        (Activation::Relu, Output::Linear, 1),
        (Activation::Tanh, Output::Tanh, 2),
    ];
    for (activation, output, outputs) in shapes {
        let c = NetConfig {
            inputs: 4,
            width: 48,
            depth: 4,
            outputs,
            activation,
            output,
            dropout: 0.0,
        };
        let (a, b) = (spread_net(c.clone(), 1), spread_net(c, 2));
        for rows in [1, 5, 7, 33, 64, 65, 97, 200, 1088] {
            let x = random_matrix(rows, 4, 2.0, rows as u64);
            let one_pass = |net: &Net| net.forward(&x, &mut Tape::default(), None).clone();
            let whole = [one_pass(&a), one_pass(&b)];
            for threads in 1..=4 {
                let workers = Workers::new(threads).expect("threads");
                let mut outs = vec![Matrix::default(); 2];
                evaluate(&[&a, &b], &x, &mut outs, &mut Vec::new(), &workers);
                let bits = |m: &Matrix| m.data.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                for (got, want) in outs.iter().zip(&whole) {
                    assert_eq!((got.rows, got.cols), (want.rows, want.cols));
                    assert_eq!(bits(got), bits(want), "{rows} rows, {threads} threads");
                }
            }
        }
    }
}
