//! Trainable multilayer perceptrons: the actor and the critic of DDPG and DCP.
//!
//! Weights are stored exactly as policy-core stores them (column-major, `w[j * outputs + o] =
//! W[o, j]`), so export is a copy, and [`Net::forward_one`] repeats policy-core's arithmetic
//! operation for operation: what the trainer evaluates is what the chip runs, bit for bit.
//!
//! The batched [`Net::forward`] / [`Net::backward`] pair is the training hot path (DCP scores 16
//! proposals per sample, so the critic sees 64 × 17 rows per update). It works on row-major
//! batches with the register-tiled loops of `net/kernels.rs`, and keeps every intermediate
//! buffer in a reusable [`Tape`], so a warm training step allocates nothing.

mod kernels;

use policy_core::Activation;
use serde::{Deserialize, Serialize};

use firmware_sim::seed;

use super::adam::flush_param;
use super::workers::Workers;

/// A row-major batch: rows are samples, columns are features; `data.len() == rows * cols`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Matrix {
    /// Number of rows (samples).
    pub rows: usize,
    /// Number of columns (features).
    pub cols: usize,
    /// The values, row after row.
    pub data: Vec<f32>,
}

impl Matrix {
    /// A `rows × cols` matrix of zeros.
    ///
    /// ```
    /// use host_trainer::nn::net::Matrix;
    /// let m = Matrix::zeros(2, 3);
    /// assert_eq!(m.data, vec![0.0; 6]);
    /// ```
    pub fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            data: vec![0.0; rows * cols],
        }
    }

    /// A matrix from row-major data.
    ///
    /// # Panics
    /// If `data.len() != rows * cols`.
    ///
    /// ```
    /// use host_trainer::nn::net::Matrix;
    /// let m = Matrix::from_vec(2, 2, vec![1.0, 2.0, 3.0, 4.0]);
    /// assert_eq!(m.row(1), &[3.0, 4.0]);
    /// ```
    pub fn from_vec(rows: usize, cols: usize, data: Vec<f32>) -> Self {
        assert_eq!(
            data.len(),
            rows * cols,
            "Matrix::from_vec: {rows} x {cols} needs {} values",
            rows * cols
        );
        Self { rows, cols, data }
    }

    /// Row `i`.
    ///
    /// ```
    /// use host_trainer::nn::net::Matrix;
    /// let m = Matrix::from_vec(2, 1, vec![5.0, 6.0]);
    /// assert_eq!(m.row(0), &[5.0]);
    /// ```
    pub fn row(&self, i: usize) -> &[f32] {
        &self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// Row `i`, mutably.
    ///
    /// ```
    /// use host_trainer::nn::net::Matrix;
    /// let mut m = Matrix::zeros(2, 2);
    /// m.row_mut(1).copy_from_slice(&[1.0, 2.0]);
    /// assert_eq!(m.data, vec![0.0, 0.0, 1.0, 2.0]);
    /// ```
    pub fn row_mut(&mut self, i: usize) -> &mut [f32] {
        &mut self.data[i * self.cols..(i + 1) * self.cols]
    }

    /// Changes the shape, keeping the allocation (contents are unspecified afterwards: callers
    /// overwrite them). This is how warm buffers are reused without allocating.
    ///
    /// ```
    /// use host_trainer::nn::net::Matrix;
    /// let mut m = Matrix::zeros(4, 4);
    /// m.reshape(2, 3);
    /// assert_eq!((m.rows, m.cols, m.data.len()), (2, 3, 6));
    /// ```
    pub fn reshape(&mut self, rows: usize, cols: usize) {
        self.rows = rows;
        self.cols = cols;
        self.data.resize(rows * cols, 0.0);
    }
}

/// What the output layer applies.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Output {
    /// `tanh`, into the unit box (actors).
    Tanh,
    /// The identity (critics).
    Linear,
}

/// The shape and regularisation of a network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NetConfig {
    /// Input features (observations; observations + actions for a critic).
    pub inputs: usize,
    /// Width of every hidden layer.
    pub width: usize,
    /// Number of hidden layers (>= 1); the paper's 4×48 has depth 4.
    pub depth: usize,
    /// Output features (actions; 1 for a critic).
    pub outputs: usize,
    /// Hidden activation.
    pub activation: Activation,
    /// Output activation.
    pub output: Output,
    /// Probability of dropping a hidden activation in training (0 = off); inverted dropout, so
    /// evaluation needs no rescaling.
    pub dropout: f32,
}

/// A dense layer, weights column-major exactly like policy-core: `w[j * outputs + o] = W[o, j]`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Layer {
    /// Input features.
    pub inputs: usize,
    /// Output features.
    pub outputs: usize,
    /// Weights, `inputs * outputs` values, column `j` (the weights from input `j`) contiguous.
    pub w: Vec<f32>,
    /// Biases, `outputs` values.
    pub b: Vec<f32>,
}

impl Layer {
    fn zeros(inputs: usize, outputs: usize) -> Self {
        Self {
            inputs,
            outputs,
            w: vec![0.0; inputs * outputs],
            b: vec![0.0; outputs],
        }
    }

    fn params(&self) -> impl Iterator<Item = &f32> {
        self.w.iter().chain(&self.b)
    }

    fn params_mut(&mut self) -> impl Iterator<Item = &mut f32> {
        self.w.iter_mut().chain(&mut self.b)
    }
}

/// A multilayer perceptron: `depth` hidden layers of `width`, then the output layer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Net {
    /// The shape this network was built with.
    pub config: NetConfig,
    /// `depth + 1` layers, input first.
    pub layers: Vec<Layer>,
}

/// Gradients of a loss with respect to every parameter, in the shapes of the layers.
#[derive(Clone, Debug, PartialEq)]
pub struct Grads {
    /// One gradient layer per network layer.
    pub layers: Vec<Layer>,
}

impl Grads {
    /// Sets every gradient to 0 (before accumulating a new batch).
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// let mut grads = net.zero_grads();
    /// grads.layers[0].w[0] = 3.0;
    /// grads.zero();
    /// assert_eq!(grads, net.zero_grads());
    /// ```
    pub fn zero(&mut self) {
        self.layers
            .iter_mut()
            .flat_map(Layer::params_mut)
            .for_each(|g| *g = 0.0);
    }

    /// Multiplies every gradient by `k` (e.g. `1 / batch` for a mean loss).
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// let mut grads = net.zero_grads();
    /// grads.layers[1].b[0] = 3.0;
    /// grads.scale(0.5);
    /// assert_eq!(grads.layers[1].b[0], 1.5);
    /// ```
    pub fn scale(&mut self, k: f32) {
        self.layers
            .iter_mut()
            .flat_map(Layer::params_mut)
            .for_each(|g| *g *= k);
    }

    /// Euclidean norm of all gradients (f64 accumulation), for logging and divergence checks.
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// let mut grads = net.zero_grads();
    /// grads.layers[0].w[0] = 3.0;
    /// grads.layers[1].b[0] = -4.0;
    /// assert_eq!(grads.norm(), 5.0);
    /// ```
    pub fn norm(&self) -> f64 {
        self.layers
            .iter()
            .flat_map(Layer::params)
            .map(|&g| f64::from(g).powi(2))
            .sum::<f64>()
            .sqrt()
    }
}

/// What [`Net::forward`] records for [`Net::backward`], plus the scratch space of the backward
/// pass. Reused from call to call: once its buffers have grown to the batch size, neither pass
/// allocates.
#[derive(Debug, Default)]
pub struct Tape {
    record: Record,
    scratch: Scratch,
}

/// A tape is scratch space: a clone starts empty (the next forward pass fills it), so a learner
/// holding tapes can be cloned without copying buffers nobody reads.
impl Clone for Tape {
    fn clone(&self) -> Self {
        Tape::default()
    }
}

#[derive(Debug, Default)]
struct Record {
    /// The input batch.
    x: Matrix,
    /// Each hidden layer's activation, before dropout.
    hidden: Vec<Matrix>,
    /// Dropout factors (0 or `1 / (1 - p)`) per hidden activation; used only when `dropout`.
    masks: Vec<Matrix>,
    /// Hidden activations after dropout (the next layer's input); used only when `dropout`.
    dropped: Vec<Matrix>,
    /// Whether the recorded pass applied dropout.
    dropout: bool,
    /// The network's output (after tanh for [`Output::Tanh`]).
    out: Matrix,
}

impl Record {
    /// The batch layer `l` consumed.
    fn layer_input(&self, l: usize) -> &Matrix {
        match l {
            0 => &self.x,
            _ if self.dropout => &self.dropped[l - 1],
            _ => &self.hidden[l - 1],
        }
    }
}

#[derive(Debug, Default)]
struct Scratch {
    /// dL/d(pre-activation) of the layer being back-propagated.
    delta: Matrix,
    /// dL/d(its input), before the activation below turns it into that layer's `delta`.
    grad_below: Matrix,
    /// Transposed copies for the backward products.
    transposed: Vec<f32>,
}

impl Net {
    /// A new network with DDPG's initialisation: hidden layers' weights and biases uniform in
    /// `±1/sqrt(fan_in)`, the output layer's in `±3e-3` (so initial actions and values are near
    /// 0 and the first gradients are not saturated).
    ///
    /// # Panics
    /// If any size is 0 (`depth` included), or `dropout` is not in `[0, 1)`.
    ///
    /// ```
    /// use host_trainer::nn::net::{Net, NetConfig, Output};
    /// use policy_core::Activation;
    /// let config = NetConfig { inputs: 2, width: 48, depth: 4, outputs: 2,
    ///     activation: Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "actor"));
    /// assert_eq!(net.layers.len(), 5);
    /// assert_eq!(net.param_count(), 2 * 48 + 48 + 3 * (48 * 48 + 48) + 48 * 2 + 2);
    /// assert!(net.layers[4].w.iter().all(|w| w.abs() <= 3e-3));
    /// ```
    pub fn new(config: NetConfig, rng: &mut impl rand_core::Rng) -> Net {
        assert!(
            config.inputs > 0 && config.width > 0 && config.depth > 0 && config.outputs > 0,
            "Net::new: every size must be positive: {config:?}"
        );
        assert!(
            (0.0..1.0).contains(&config.dropout),
            "Net::new: dropout must be in [0, 1), found {}",
            config.dropout
        );
        let last = config.depth;
        let layers = (0..=last)
            .map(|l| {
                let inputs = if l == 0 { config.inputs } else { config.width };
                let outputs = if l == last {
                    config.outputs
                } else {
                    config.width
                };
                let bound = if l == last {
                    3e-3
                } else {
                    1.0 / (inputs as f32).sqrt()
                };
                let mut layer = Layer::zeros(inputs, outputs);
                layer
                    .params_mut()
                    .for_each(|p| *p = seed::uniform_in(rng, -bound, bound));
                layer
            })
            .collect();
        Net { config, layers }
    }

    /// Runs one sample without dropout: `out` gets the output (after tanh for [`Output::Tanh`],
    /// where a non-finite value becomes 0). `x` is already normalised.
    ///
    /// The arithmetic is policy-core's, step for step (bias first, then `y[o] += W[o, j] * x[j]`
    /// for `j` ascending, `libm::tanhf`), so an exported policy returns exactly these values.
    ///
    /// # Panics
    /// If `x` or `out` does not have the network's input or output size.
    ///
    /// ```
    /// use host_trainer::nn::net::{Net, NetConfig, Output};
    /// use policy_core::Activation;
    /// let config = NetConfig { inputs: 2, width: 8, depth: 2, outputs: 1,
    ///     activation: Activation::Relu, output: Output::Linear, dropout: 0.5 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "critic"));
    /// let mut q = [0.0];
    /// net.forward_one(&[0.3, -0.2], &mut q);
    /// assert!(q[0].is_finite() && q[0].abs() < 0.1);
    /// ```
    pub fn forward_one(&self, x: &[f32], out: &mut [f32]) {
        assert_eq!(x.len(), self.config.inputs, "Net::forward_one: input size");
        assert_eq!(
            out.len(),
            self.config.outputs,
            "Net::forward_one: output size"
        );
        let width = self.config.width;
        let mut act = x.to_vec();
        let mut pre = Vec::with_capacity(width);
        for (l, layer) in self.layers.iter().enumerate() {
            if l > 0 {
                act.clear();
                act.extend(pre.iter().map(|&v| self.config.activation.apply(v)));
            }
            pre.clear();
            pre.extend_from_slice(&layer.b);
            kernels::accumulate_one(&layer.w, &act, &mut pre);
        }
        for (o, &y) in out.iter_mut().zip(&pre) {
            *o = self.squash(y);
        }
    }

    fn squash(&self, y: f32) -> f32 {
        match self.config.output {
            Output::Linear => y,
            Output::Tanh => policy_core::mlp::squash(y),
        }
    }

    /// Runs a batch (one sample per row) and records it in `tape` for [`Net::backward`].
    ///
    /// `dropout_rng: Some(rng)` is training mode: each hidden activation is dropped with the
    /// configured probability and the survivors are scaled by `1 / (1 - p)`. `None` is
    /// evaluation mode (deterministic). The sums are policy-core's, in the same order; only
    /// tanh differs (a vectorised approximation within a few ulp of `libm::tanhf`), so the
    /// result agrees with [`Net::forward_one`] to about 1e-6, not bit for bit.
    ///
    /// # Panics
    /// If `x.cols` is not the network's input size.
    ///
    /// ```
    /// use host_trainer::nn::net::{Matrix, Net, NetConfig, Output, Tape};
    /// use policy_core::Activation;
    /// let config = NetConfig { inputs: 2, width: 16, depth: 2, outputs: 2,
    ///     activation: Activation::Tanh, output: Output::Tanh, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "actor"));
    /// let x = Matrix::from_vec(2, 2, vec![0.1, 0.2, -1.0, 0.5]);
    /// let mut tape = Tape::default();
    /// let y = net.forward(&x, &mut tape, None).clone();
    /// let mut one = [0.0; 2];
    /// net.forward_one(x.row(1), &mut one);
    /// assert!((y.row(1)[0] - one[0]).abs() < 1e-6);
    /// ```
    pub fn forward<'t>(
        &self,
        x: &Matrix,
        tape: &'t mut Tape,
        dropout_rng: Option<&mut seed::SimRng>,
    ) -> &'t Matrix {
        assert_eq!(x.cols, self.config.inputs, "Net::forward: input columns");
        self.forward_rows(&x.data, x.rows, tape, dropout_rng)
    }

    /// [`Net::forward`] on `rows` row-major rows of input data (a slice of a larger batch).
    fn forward_rows<'t>(
        &self,
        x: &[f32],
        rows: usize,
        tape: &'t mut Tape,
        dropout_rng: Option<&mut seed::SimRng>,
    ) -> &'t Matrix {
        let rec = &mut tape.record;
        let rng = dropout_rng.filter(|_| self.config.dropout > 0.0);
        rec.dropout = rng.is_some();
        rec.x.reshape(rows, self.config.inputs);
        rec.x.data.copy_from_slice(x);
        self.hidden_layers(rec, rng);
        let depth = self.config.depth;
        let mut out = std::mem::take(&mut rec.out);
        kernels::affine(rec.layer_input(depth), &self.layers[depth], &mut out);
        if self.config.output == Output::Tanh {
            kernels::squash_tanh(&mut out.data);
        }
        rec.out = out;
        &rec.out
    }

    /// The hidden layers of [`Net::forward`]: affine, activation, dropout, layer by layer.
    fn hidden_layers(&self, rec: &mut Record, mut rng: Option<&mut seed::SimRng>) {
        let depth = self.config.depth;
        for store in [&mut rec.hidden, &mut rec.masks, &mut rec.dropped] {
            store.resize_with(depth, Matrix::default);
        }
        for l in 0..depth {
            let (hidden_below, hidden) = rec.hidden.split_at_mut(l);
            let (dropped_below, dropped) = rec.dropped.split_at_mut(l);
            let input = match l {
                0 => &rec.x,
                _ if rec.dropout => &dropped_below[l - 1],
                _ => &hidden_below[l - 1],
            };
            let h = &mut hidden[0];
            let activation = Some(self.config.activation);
            kernels::affine_then(input, &self.layers[l], activation, h);
            if let Some(rng) = rng.as_deref_mut() {
                kernels::dropout(
                    h,
                    self.config.dropout,
                    rng,
                    &mut rec.masks[l],
                    &mut dropped[0],
                );
            }
        }
    }

    /// Back-propagates `grad_out` = dL/d(output) (the output as [`Net::forward`] returned it,
    /// after tanh for actors) through the pass recorded in `tape`.
    ///
    /// The parameter gradients are ADDED into `grads` (call [`Grads::zero`] first); the return
    /// value is dL/d(input), one row per sample, which DDPG needs for dQ/da.
    ///
    /// # Panics
    /// If `grad_out` does not have the recorded output's shape.
    ///
    /// ```
    /// use host_trainer::nn::net::{Matrix, Net, NetConfig, Output, Tape};
    /// use policy_core::Activation;
    /// let config = NetConfig { inputs: 3, width: 8, depth: 2, outputs: 1,
    ///     activation: Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(1, "critic"));
    /// let mut tape = Tape::default();
    /// net.forward(&Matrix::from_vec(1, 3, vec![0.5, 0.1, -0.3]), &mut tape, None);
    /// let mut grads = net.zero_grads();
    /// let dx = net.backward(&tape, &Matrix::from_vec(1, 1, vec![1.0]), &mut grads);
    /// assert_eq!((dx.rows, dx.cols), (1, 3));
    /// // dQ/d(output bias) is 1.
    /// assert_eq!(grads.layers[2].b, vec![1.0]);
    /// ```
    pub fn backward(&self, tape: &Tape, grad_out: &Matrix, grads: &mut Grads) -> Matrix {
        let mut dx = Matrix::default();
        self.backward_with(
            &tape.record,
            &mut Scratch::default(),
            grad_out,
            Some(grads),
            &mut dx,
        );
        dx
    }

    /// [`Net::backward`] without allocating: the scratch space lives in `tape` and dL/d(input)
    /// is written into `dx` (reshaped to `rows × inputs`).
    ///
    /// ```
    /// use host_trainer::nn::net::{Matrix, Net, NetConfig, Output, Tape};
    /// use policy_core::Activation;
    /// let config = NetConfig { inputs: 2, width: 8, depth: 1, outputs: 2,
    ///     activation: Activation::Relu, output: Output::Tanh, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(2, "actor"));
    /// let x = Matrix::from_vec(2, 2, vec![0.5, 0.1, -0.3, 0.2]);
    /// let g = Matrix::from_vec(2, 2, vec![1.0, 0.0, 0.0, 1.0]);
    /// let (mut tape, mut grads, mut dx) = (Tape::default(), net.zero_grads(), Matrix::default());
    /// net.forward(&x, &mut tape, None);
    /// net.backward_into(&mut tape, &g, &mut grads, &mut dx);
    /// let mut fresh = net.zero_grads();
    /// assert_eq!(net.backward(&tape, &g, &mut fresh), dx);
    /// assert_eq!(fresh, grads);
    /// ```
    pub fn backward_into(
        &self,
        tape: &mut Tape,
        grad_out: &Matrix,
        grads: &mut Grads,
        dx: &mut Matrix,
    ) {
        self.backward_with(&tape.record, &mut tape.scratch, grad_out, Some(grads), dx);
    }

    /// Only dL/d(input), without parameter gradients: DDPG's dQ/da through the critic costs
    /// about half a full backward pass this way.
    ///
    /// ```
    /// use host_trainer::nn::net::{Matrix, Net, NetConfig, Output, Tape};
    /// use policy_core::Activation;
    /// let config = NetConfig { inputs: 4, width: 8, depth: 2, outputs: 1,
    ///     activation: Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let critic = Net::new(config, &mut firmware_sim::seed::training_stream(1, "critic"));
    /// let (mut tape, mut dq) = (Tape::default(), Matrix::default());
    /// let sa = Matrix::from_vec(1, 4, vec![0.5, 0.1, -0.3, 0.9]);
    /// critic.forward(&sa, &mut tape, None);
    /// let ones = Matrix::from_vec(1, 1, vec![1.0]);
    /// critic.input_grads_into(&mut tape, &ones, &mut dq);
    /// let full = critic.backward(&tape, &ones, &mut critic.zero_grads());
    /// assert_eq!(dq, full); // dQ/d[obs, action]; the action part is dq.row(0)[2..]
    /// ```
    pub fn input_grads_into(&self, tape: &mut Tape, grad_out: &Matrix, dx: &mut Matrix) {
        self.backward_with(&tape.record, &mut tape.scratch, grad_out, None, dx);
    }

    fn backward_with(
        &self,
        rec: &Record,
        scratch: &mut Scratch,
        grad_out: &Matrix,
        mut grads: Option<&mut Grads>,
        dx: &mut Matrix,
    ) {
        assert_eq!(
            (grad_out.rows, grad_out.cols),
            (rec.out.rows, rec.out.cols),
            "Net::backward: grad_out shape"
        );
        let Scratch {
            delta,
            grad_below,
            transposed,
        } = scratch;
        delta.reshape(grad_out.rows, grad_out.cols);
        delta.data.copy_from_slice(&grad_out.data);
        if self.config.output == Output::Tanh {
            // d tanh(y) / dy = 1 - tanh(y)²; an output forced to 0 (non-finite) passes 1, which
            // cannot matter: such a pass has already diverged and is caught by `is_finite`.
            delta
                .data
                .iter_mut()
                .zip(&rec.out.data)
                .for_each(|(d, &u)| *d *= 1.0 - u * u);
        }
        for l in (0..self.layers.len()).rev() {
            let layer = &self.layers[l];
            if let Some(grads) = grads.as_deref_mut() {
                kernels::accumulate_grads(rec.layer_input(l), delta, &mut grads.layers[l]);
            }
            if l == 0 {
                kernels::input_grads(delta, layer, dx, transposed);
            } else {
                kernels::input_grads(delta, layer, grad_below, transposed);
                let mask = rec.dropout.then(|| &rec.masks[l - 1]);
                kernels::activation_grads(
                    self.config.activation,
                    &rec.hidden[l - 1],
                    mask,
                    grad_below,
                    delta,
                );
            }
        }
    }

    /// Zero gradients in this network's shape.
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// assert_eq!(net.zero_grads().norm(), 0.0);
    /// ```
    pub fn zero_grads(&self) -> Grads {
        Grads {
            layers: self
                .layers
                .iter()
                .map(|l| Layer::zeros(l.inputs, l.outputs))
                .collect(),
        }
    }

    /// Multiply-adds of one row through the forward pass (Σ inputs × outputs over the layers);
    /// a backward pass with weight and input gradients costs twice this. Benchmarks count work
    /// with it.
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// assert_eq!(net.multiply_adds(), 2 * 4 + 4);
    /// ```
    pub fn multiply_adds(&self) -> u64 {
        self.layers
            .iter()
            .map(|l| (l.inputs * l.outputs) as u64)
            .sum()
    }

    /// Number of parameters (weights and biases).
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// assert_eq!(net.param_count(), 2 * 4 + 4 + 4 + 1);
    /// ```
    pub fn param_count(&self) -> usize {
        self.layers.iter().map(|l| l.w.len() + l.b.len()).sum()
    }

    /// Whether every parameter is finite (training stops when one is not).
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let mut net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// assert!(net.is_finite());
    /// net.layers[0].w[3] = f32::NAN;
    /// assert!(!net.is_finite());
    /// ```
    pub fn is_finite(&self) -> bool {
        self.layers
            .iter()
            .flat_map(Layer::params)
            .all(|p| p.is_finite())
    }

    /// Whether the layers have the sizes the config promises (fields are public, so a network
    /// read from a checkpoint is checked before it is exported).
    ///
    /// ```
    /// # use host_trainer::nn::net::{Net, NetConfig, Output};
    /// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
    /// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
    /// let mut net = Net::new(config, &mut firmware_sim::seed::training_stream(0, "n"));
    /// assert!(net.is_consistent());
    /// net.layers[1].b.push(0.0);
    /// assert!(!net.is_consistent());
    /// ```
    pub fn is_consistent(&self) -> bool {
        let c = &self.config;
        self.layers.len() == c.depth + 1
            && self.layers.iter().enumerate().all(|(l, layer)| {
                let inputs = if l == 0 { c.inputs } else { c.width };
                let outputs = if l == c.depth { c.outputs } else { c.width };
                layer.inputs == inputs
                    && layer.outputs == outputs
                    && layer.w.len() == inputs * outputs
                    && layer.b.len() == outputs
            })
    }
}

/// Rows per parallel task of [`evaluate`] at least: below this a task costs more to hand to a
/// thread than it saves. Measured (`update_threads` bench, 2 vCPUs of an AMD EPYC): at 32, a
/// batch of 64 was split in two and DDPG's update took 345 µs on 2 threads against 283 µs on
/// one; a hand-off to a sleeping worker costs tens of µs on this virtual machine. At 64 a batch
/// of 64 stays whole and DCP's 64 × 17 proposal rows still split.
const MIN_TASK_ROWS: usize = 64;

/// The row height of the kernels' register tiles: [`evaluate`] splits batches at multiples of
/// it, so every task but the last runs whole tiles, as the whole batch would.
const TILE_ROWS: usize = 6;

/// Inference passes (no dropout) of several networks over the same batch `x`, their outputs in
/// `outs` (`outs[i]` for `nets[i]`, reshaped to `x.rows × outputs`). The rows are split over
/// `workers` at multiples of the kernels' tile height, each network's part its own task.
///
/// Every output row is computed by the instructions a single pass over the whole batch uses
/// for that row (each row's sums run over its own inputs only, in the same order, whatever tile
/// holds it: `kernels.rs`), so the outputs are the same bits for any split and thread count.
/// `tapes` is scratch space, one tape per task, kept for the next call.
///
/// # Panics
/// If `outs` is shorter than `nets`, or `x.cols` is not every network's input size.
///
/// ```
/// use host_trainer::nn::net::{evaluate, Matrix, Net, NetConfig, Output, Tape};
/// use host_trainer::nn::workers::Workers;
/// use policy_core::Activation;
/// let config = NetConfig { inputs: 3, width: 16, depth: 2, outputs: 1,
///     activation: Activation::Relu, output: Output::Linear, dropout: 0.0 };
/// let q1 = Net::new(config.clone(), &mut firmware_sim::seed::training_stream(1, "critic"));
/// let q2 = Net::new(config, &mut firmware_sim::seed::training_stream(2, "critic"));
/// let x = Matrix::from_vec(100, 3, (0..300).map(|i| (i as f32 * 0.1).sin()).collect());
/// let mut outs = vec![Matrix::default(); 2];
/// evaluate(&[&q1, &q2], &x, &mut outs, &mut Vec::new(), &Workers::new(3).expect("threads"));
/// let mut tape = Tape::default();
/// let whole = q2.forward(&x, &mut tape, None);
/// assert_eq!(&outs[1], whole);
/// ```
pub fn evaluate(
    nets: &[&Net],
    x: &Matrix,
    outs: &mut [Matrix],
    tapes: &mut Vec<Tape>,
    workers: &Workers,
) {
    assert!(outs.len() >= nets.len(), "evaluate: one output per network");
    for net in nets {
        assert_eq!(x.cols, net.config.inputs, "evaluate: input columns");
    }
    // Enough tasks to give every thread work, none smaller than MIN_TASK_ROWS.
    let per_net = workers
        .threads()
        .div_ceil(nets.len().max(1))
        .min(x.rows / MIN_TASK_ROWS)
        .max(1);
    let chunk = x.rows.div_ceil(per_net).next_multiple_of(TILE_ROWS).max(1);
    struct Task<'a> {
        net: &'a Net,
        x: &'a [f32],
        out: &'a mut [f32],
        tape: &'a mut Tape,
    }
    let tasks_needed = nets.len() * x.rows.div_ceil(chunk);
    if tapes.len() < tasks_needed {
        tapes.resize_with(tasks_needed, Tape::default);
    }
    let mut tapes = tapes.iter_mut();
    let mut tasks = Vec::with_capacity(tasks_needed);
    for (net, out) in nets.iter().zip(outs.iter_mut()) {
        out.reshape(x.rows, net.config.outputs);
        let outputs = net.config.outputs;
        let parts = x
            .data
            .chunks(chunk * x.cols)
            .zip(out.data.chunks_mut(chunk * outputs));
        for ((x, out), tape) in parts.zip(&mut tapes) {
            tasks.push(Task { net, x, out, tape });
        }
    }
    workers.for_each(&mut tasks, |t| {
        let rows = t.out.len() / t.net.config.outputs;
        let y = t.net.forward_rows(t.x, rows, t.tape, None);
        t.out.copy_from_slice(&y.data);
    });
}

/// Polyak averaging of target networks: `target <- tau * source + (1 - tau) * target`, each
/// result below 2⁻⁹⁰ in magnitude set to zero as Adam's step sets its parameters
/// (`nn::adam`'s docs say why).
///
/// # Panics
/// If the two networks do not have the same shape.
///
/// ```
/// use host_trainer::nn::net::{soft_update, Net, NetConfig, Output};
/// # let config = NetConfig { inputs: 2, width: 4, depth: 1, outputs: 1,
/// #     activation: policy_core::Activation::Tanh, output: Output::Linear, dropout: 0.0 };
/// let source = Net::new(config.clone(), &mut firmware_sim::seed::training_stream(1, "n"));
/// let mut target = Net::new(config, &mut firmware_sim::seed::training_stream(2, "n"));
/// soft_update(&mut target, &source, 1.0);
/// assert_eq!(target, source);
/// ```
pub fn soft_update(target: &mut Net, source: &Net, tau: f32) {
    assert_eq!(
        target.param_count(),
        source.param_count(),
        "soft_update: network shapes differ"
    );
    let keep = 1.0 - tau;
    // Flushed as Adam's step flushes its parameters (`nn::adam::flush_param`): a target
    // weight whose source is zero decays by `keep` each update into the subnormal range and
    // sticks there (below about 100 · 2⁻¹⁴⁹, `keep * t` rounds back to `t`), where every
    // target pass that reads it pays the CPU's microcode assist.
    // Slice by slice, not through the chained `params_mut` iterator: that one does not
    // vectorise, and this loop runs over every parameter of two networks per update.
    let blend = |t: &mut [f32], s: &[f32]| {
        for (t, &s) in t.iter_mut().zip(s) {
            *t = flush_param(tau * s + keep * *t);
        }
    };
    for (t, s) in target.layers.iter_mut().zip(&source.layers) {
        blend(&mut t.w, &s.w);
        blend(&mut t.b, &s.b);
    }
}

#[cfg(test)]
mod tests;
