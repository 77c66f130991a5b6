//! Adam, with L2 regularisation of the weights (the paper's 1e-4).
//!
//! Every moment the step writes is flushed to zero when it is subnormal (below 2⁻¹²⁶ in
//! magnitude), and every parameter when it is below 2⁻⁹⁰ (`flush_param` says why that
//! bound). The weights of a ReLU unit that no longer fires get no gradient but the L2 term's,
//! which Adam drives towards zero by ever smaller steps, into the subnormal range; on CPUs that
//! handle subnormal operands and results in microcode (the Intel Xeons of docs/performance.md)
//! every multiply-add that meets one is about 90 times slower, and training several times
//! slower as a whole. A product with so small a weight is below half an ulp of any sum of
//! normal size, so flushing the weight leaves the sums, and so every activation, gradient and
//! decision of training, as they were: only those weights' own bits change
//! (docs/performance.md, "Subnormal numbers on Intel Xeon", measures both). In code, not by the
//! CPU's flush-to-zero mode, so that every machine computes the same bits.

use serde::{Deserialize, Serialize};

use super::net::{Grads, Layer, Net};

/// The Adam optimiser for one network; its moments are shaped like the network's layers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Adam {
    /// Learning rate (the paper's 1/4096).
    pub lr: f32,
    /// Decay of the first moment.
    pub beta1: f32,
    /// Decay of the second moment.
    pub beta2: f32,
    /// Added to the root of the second moment.
    pub eps: f32,
    /// L2 coefficient: `l2 * w` is added to every weight's gradient (biases are not decayed).
    pub l2: f32,
    /// Steps taken (for the bias correction).
    pub steps: u64,
    /// First moments.
    m: Vec<Layer>,
    /// Second moments.
    v: Vec<Layer>,
}

impl Adam {
    /// An optimiser for `net` with `beta1 = 0.9`, `beta2 = 0.999`, `eps = 1e-8`.
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// use host_trainer::nn::adam::Adam;
    /// let mut net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// let mut adam = Adam::new(&net, 1e-3, 0.0);
    /// let mut grads = net.zero_grads();
    /// grads.layers[1].b[0] = 2.0;
    /// let before = net.layers[1].b[0];
    /// adam.step(&mut net, &grads);
    /// // Adam's first step moves each parameter by about lr against its gradient's sign.
    /// assert!((before - net.layers[1].b[0] - 1e-3).abs() < 1e-6);
    /// ```
    pub fn new(net: &Net, lr: f32, l2: f32) -> Adam {
        let zeros = net.zero_grads().layers;
        Adam {
            lr,
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
            l2,
            steps: 0,
            m: zeros.clone(),
            v: zeros,
        }
    }

    /// One step against `grads` (which are not modified; the L2 term is added on the fly).
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// use host_trainer::nn::adam::Adam;
    /// let mut net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// let mut adam = Adam::new(&net, 1e-2, 0.0);
    /// let mut grads = net.zero_grads();
    /// grads.layers[0].w[0] = -0.5; // the loss falls as this weight grows
    /// let before = net.layers[0].w[0];
    /// for _ in 0..3 {
    ///     adam.step(&mut net, &grads);
    /// }
    /// assert_eq!(adam.steps, 3);
    /// assert!(net.layers[0].w[0] > before + 0.029);
    /// ```
    ///
    /// # Panics
    /// If `net` or `grads` does not have the shape the optimiser was built for.
    pub fn step(&mut self, net: &mut Net, grads: &Grads) {
        assert_eq!(net.layers.len(), self.m.len(), "Adam::step: network shape");
        assert_eq!(
            grads.layers.len(),
            self.m.len(),
            "Adam::step: gradient shape"
        );
        self.steps += 1;
        let step = Step::at(self.steps, self.lr, self.beta1, self.beta2, self.eps);
        for (((layer, g), m), v) in net
            .layers
            .iter_mut()
            .zip(&grads.layers)
            .zip(&mut self.m)
            .zip(&mut self.v)
        {
            step.apply(&mut layer.w, &g.w, &mut m.w, &mut v.w, self.l2);
            step.apply(&mut layer.b, &g.b, &mut m.b, &mut v.b, 0.0);
        }
    }
}

/// Adam for a plain parameter vector that is not a network (PPO's state-independent
/// log-standard-deviation), with [`Adam`]'s constants and no weight decay.
///
/// ```
/// use host_trainer::nn::adam::VecAdam;
/// let mut p = vec![1.0f32, -1.0];
/// let mut adam = VecAdam::new(2, 0.1);
/// adam.step(&mut p, &[1.0, -1.0]);
/// assert!((p[0] - 0.9).abs() < 1e-6 && (p[1] + 0.9).abs() < 1e-6);
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VecAdam {
    /// Learning rate.
    pub lr: f32,
    /// Steps taken (for the bias correction).
    pub steps: u64,
    m: Vec<f32>,
    v: Vec<f32>,
}

impl VecAdam {
    /// Adam at rest for `len` parameters.
    pub fn new(len: usize, lr: f32) -> VecAdam {
        VecAdam {
            lr,
            steps: 0,
            m: vec![0.0; len],
            v: vec![0.0; len],
        }
    }

    /// One step of `p` against the gradient `g`.
    ///
    /// # Panics
    /// If `p` or `g` does not have the length given to [`VecAdam::new`].
    pub fn step(&mut self, p: &mut [f32], g: &[f32]) {
        assert_eq!(p.len(), self.m.len(), "VecAdam::step: parameter length");
        self.steps += 1;
        let step = Step::at(self.steps, self.lr, 0.9, 0.999, 1e-8);
        step.apply(p, g, &mut self.m, &mut self.v, 0.0);
    }
}

/// `x`, or zero where `x` is subnormal (the module docs say why).
#[inline(always)]
fn flush(x: f32) -> f32 {
    if x.is_subnormal() {
        0.0
    } else {
        x
    }
}

/// Below this magnitude (2⁻⁹⁰, about 8 × 10⁻²⁸) a parameter is set to zero: see
/// [`flush_param`].
pub(crate) const TINY_PARAM: f32 = f32::from_bits((127 - 90) << 23);

/// A parameter, or zero where its magnitude is below [`TINY_PARAM`] (zero and NaN pass as
/// they are).
///
/// Flushing only subnormal parameters is not enough: the outgoing weights of a ReLU unit that
/// no longer fires get no gradient but the L2 term's, and Adam's moments, still decaying, walk
/// a flushed weight back to about 10⁻³⁷. Such a weight is normal, but the backward pass
/// multiplies it by the next layer's gradients (about 10⁻³ and above) into subnormal results,
/// and every multiply-add that produces one pays the CPU's microcode assist. Above 2⁻⁹⁰ a
/// weight's products with gradients above 2⁻³⁶ are normal; below it, its product with any
/// activation or gradient under 2¹⁰ is below 2⁻⁸⁰, under half an ulp of any sum above 2⁻⁵⁶
/// (about 10⁻¹⁷), so the sums that training reads keep their bits (docs/performance.md,
/// "Subnormal numbers on Intel Xeon", checks it over whole runs). Once a weight is zero and
/// its moments have decayed, its gradient is exactly zero and it stays zero until its unit
/// fires.
#[inline(always)]
pub(crate) fn flush_param(x: f32) -> f32 {
    if x != 0.0 && x.abs() < TINY_PARAM {
        0.0
    } else {
        x
    }
}

/// The per-parameter update of one step.
struct Step {
    lr: f32,
    inv_c2: f32,
    beta1: f32,
    beta2: f32,
    eps: f32,
}

impl Step {
    /// Step number `steps` (from 1), with Adam's bias corrections folded into the step size,
    /// computed in f64 (they approach 1 slowly).
    fn at(steps: u64, lr: f32, beta1: f32, beta2: f32, eps: f32) -> Step {
        let t = steps.min(i32::MAX as u64) as i32;
        let c1 = 1.0 - f64::from(beta1).powi(t);
        let c2 = 1.0 - f64::from(beta2).powi(t);
        Step {
            lr: (f64::from(lr) / c1) as f32,
            inv_c2: (1.0 / c2) as f32,
            beta1,
            beta2,
            eps,
        }
    }

    fn apply(&self, p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32], l2: f32) {
        assert_eq!(p.len(), g.len(), "Adam::step: gradient shape");
        for (((p, &g), m), v) in p.iter_mut().zip(g).zip(m.iter_mut()).zip(v.iter_mut()) {
            let g = g + l2 * *p;
            *m = self.beta1 * *m + (1.0 - self.beta1) * g;
            *v = self.beta2 * *v + (1.0 - self.beta2) * g * g;
            *p = flush_param(*p - self.lr * *m / ((*v * self.inv_c2).sqrt() + self.eps));
            *m = flush(*m);
            *v = flush(*v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nn::net::{Matrix, NetConfig, Output, Tape};
    use firmware_sim::seed::training_stream;
    use policy_core::Activation;

    /// Mean squared error of a small regression; returns the loss and fills `grads`.
    fn mse(net: &Net, x: &Matrix, target: &[f32], tape: &mut Tape, grads: &mut Grads) -> f32 {
        let y = net.forward(x, tape, None).clone();
        let n = target.len() as f32;
        let diff: Vec<f32> = y.data.iter().zip(target).map(|(y, t)| y - t).collect();
        let g = Matrix::from_vec(y.rows, 1, diff.iter().map(|d| 2.0 * d / n).collect());
        grads.zero();
        net.backward(tape, &g, grads);
        diff.iter().map(|d| d * d).sum::<f32>() / n
    }

    #[test]
    fn adam_fits_a_regression() {
        let config = NetConfig {
            inputs: 2,
            width: 16,
            depth: 2,
            outputs: 1,
            activation: Activation::Tanh,
            output: Output::Linear,
            dropout: 0.0,
        };
        let mut net = Net::new(config, &mut training_stream(1, "adam"));
        let mut rng = training_stream(2, "data");
        let xs: Vec<f32> = (0..64)
            .map(|_| firmware_sim::seed::uniform_in(&mut rng, -1.0, 1.0))
            .collect();
        let x = Matrix::from_vec(32, 2, xs);
        let target: Vec<f32> = (0..32)
            .map(|r| x.row(r)[0] * 0.5 - x.row(r)[1] * x.row(r)[0])
            .collect();
        let (mut tape, mut grads) = (Tape::default(), net.zero_grads());
        let mut adam = Adam::new(&net, 1e-2, 0.0);
        let first = mse(&net, &x, &target, &mut tape, &mut grads);
        for _ in 0..300 {
            mse(&net, &x, &target, &mut tape, &mut grads);
            adam.step(&mut net, &grads);
        }
        let last = mse(&net, &x, &target, &mut tape, &mut grads);
        assert!(last < first * 0.05, "loss {first} -> {last}");
    }

    #[test]
    fn weights_and_moments_never_stay_subnormal() {
        // A weight with no gradient but the L2 term's, as a ReLU unit that no longer fires has:
        // Adam walks it towards zero by shrinking steps, into the subnormal range, where the
        // flush stops it at zero. Without the flush, thousands of steps leave it subnormal.
        let mut adam = Adam::new(
            &Net::new(tiny(), &mut training_stream(5, "adam")),
            1e-3,
            1e-4,
        );
        let (mut p, mut m, mut v) = ([1e-30f32, -3e-35, 0.5], [0.0f32; 3], [0.0f32; 3]);
        let mut seen_tiny = false;
        for _ in 0..5_000 {
            adam.steps += 1;
            let step = Step {
                lr: adam.lr,
                inv_c2: 1.0,
                beta1: adam.beta1,
                beta2: adam.beta2,
                eps: adam.eps,
            };
            step.apply(&mut p, &[0.0; 3], &mut m, &mut v, adam.l2);
            for x in p.iter().chain(&m).chain(&v) {
                assert!(!x.is_subnormal(), "{x:e} left subnormal");
                seen_tiny |= *x != 0.0 && x.abs() < 1e-30;
            }
        }
        assert!(
            seen_tiny,
            "the walk towards zero passed near the subnormal range"
        );
        assert_eq!(flush(f32::MIN_POSITIVE), f32::MIN_POSITIVE);
        assert_eq!(flush(f32::MIN_POSITIVE / 2.0), 0.0);
        assert_eq!(flush(-f32::from_bits(1)), 0.0);
        assert!(flush(-0.0).is_sign_negative() && flush(f32::NAN).is_nan());
    }

    #[test]
    fn a_weight_whose_unit_stopped_firing_ends_at_zero_and_stays_there() {
        // The outgoing weight of a unit that fired and then stopped: a gradient while it
        // fired, then only the L2 term's. Adam's moments, still decaying, keep moving a weight
        // that a subnormal-only flush set to zero, back to about 1e-37, a normal number whose
        // products with gradients are subnormal; `flush_param` holds it at zero instead.
        let adam = Adam::new(
            &Net::new(tiny(), &mut training_stream(5, "adam")),
            2.0f32.powi(-12),
            1e-4,
        );
        let (mut p, mut m, mut v) = ([0.3f32, -0.2], [0.0f32; 2], [0.0f32; 2]);
        let mut zero_from = None;
        for step in 1..=40_000u32 {
            let apply = Step::at(u64::from(step), adam.lr, adam.beta1, adam.beta2, adam.eps);
            let g = if step <= 200 { [0.01, -0.02] } else { [0.0; 2] };
            apply.apply(&mut p, &g, &mut m, &mut v, adam.l2);
            for x in p {
                assert!(
                    x == 0.0 || x.abs() >= TINY_PARAM,
                    "{x:e} at step {step}: a weight this small makes subnormal products"
                );
            }
            match (zero_from, p == [0.0; 2]) {
                (None, true) => zero_from = Some(step),
                (Some(at), false) => panic!("zero at step {at}, then {p:?} at step {step}"),
                _ => {}
            }
        }
        assert!(zero_from.is_some(), "the weights never reached zero: {p:?}");
        assert_eq!(flush_param(TINY_PARAM), TINY_PARAM);
        assert_eq!(flush_param(-TINY_PARAM / 2.0), 0.0);
        assert_eq!(TINY_PARAM, 2.0f32.powi(-90));
        assert!(flush_param(-0.0).is_sign_negative() && flush_param(f32::NAN).is_nan());
    }

    fn tiny() -> NetConfig {
        NetConfig {
            inputs: 1,
            width: 1,
            depth: 1,
            outputs: 1,
            activation: Activation::Relu,
            output: Output::Linear,
            dropout: 0.0,
        }
    }

    #[test]
    fn l2_shrinks_weights_not_biases() {
        let config = NetConfig {
            inputs: 2,
            width: 4,
            depth: 1,
            outputs: 1,
            activation: Activation::Relu,
            output: Output::Linear,
            dropout: 0.0,
        };
        let mut net = Net::new(config, &mut training_stream(3, "adam"));
        let before = net.clone();
        let grads = net.zero_grads();
        let mut adam = Adam::new(&net, 1e-3, 1e-2);
        for _ in 0..10 {
            adam.step(&mut net, &grads);
        }
        for (a, b) in net.layers.iter().zip(&before.layers) {
            assert_eq!(a.b, b.b, "biases are not decayed");
            // Adam moves each weight by about lr per step against sign(l2 * w): 10 steps shrink
            // every weight larger than 10 * lr (smaller ones may overshoot 0).
            for (&wa, &wb) in a.w.iter().zip(&b.w).filter(|(_, wb)| wb.abs() > 0.02) {
                assert!(
                    wa.abs() < wb.abs() && wa.signum() == wb.signum(),
                    "weight {wb} -> {wa} should shrink toward 0"
                );
                assert!(
                    (wb.abs() - wa.abs() - 0.01).abs() < 1e-3,
                    "weight {wb} -> {wa}: about 10 steps of lr"
                );
            }
        }
    }
}
