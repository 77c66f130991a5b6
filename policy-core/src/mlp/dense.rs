//! The compiled layers: [`Dense`] and [`Trunk`] hold their weights in nalgebra matrices with
//! sizes in their types, and compute through the same kernels ([`super::kernels`]) and
//! activations as the runtime model runs a blob with, so they give the same bits.

use nalgebra::{ArrayStorage, SMatrix, SVector};

use super::activation::{activate, Activation};
use super::kernels::accumulate;

/// A dense layer `y = b + W x` with `I` inputs and `O` outputs.
///
/// `w` is stored column-major (nalgebra's layout): column `j` holds the weights from input `j`.
#[derive(Clone, Debug, PartialEq)]
pub struct Dense<const I: usize, const O: usize> {
    /// Weights, `O` rows by `I` columns.
    pub w: SMatrix<f32, O, I>,
    /// Biases.
    pub b: SVector<f32, O>,
}

impl<const I: usize, const O: usize> Dense<I, O> {
    /// The all-zero layer; usable in `const` and `static` initialisers.
    pub const ZERO: Self = Self {
        w: SMatrix::from_array_storage(ArrayStorage([[0.0; O]; I])),
        b: SVector::from_array_storage(ArrayStorage([[0.0; O]; 1])),
    };

    /// Adds `W x` to `y`; see [`accumulate`].
    #[inline]
    pub fn accumulate(&self, x: &[f32], y: &mut SVector<f32, O>) {
        accumulate(&self.w, x, y);
    }

    /// `b + W x`.
    ///
    /// ```
    /// use policy_core::mlp::Dense;
    /// let mut d = Dense::<2, 1>::ZERO;
    /// d.w[(0, 0)] = 2.0;
    /// d.w[(0, 1)] = -1.0;
    /// d.b[0] = 0.5;
    /// let y = d.affine(&[3.0, 4.0]);
    /// assert_eq!(y[0], 0.5 + 6.0 - 4.0);
    /// ```
    #[inline]
    pub fn affine(&self, x: &[f32; I]) -> SVector<f32, O> {
        let mut y = self.b;
        self.accumulate(x, &mut y);
        y
    }

    /// The parameters as slices, in blob order: weights (column-major), then biases.
    ///
    /// ```
    /// use policy_core::Dense;
    /// let mut d = Dense::<2, 3>::ZERO;
    /// d.w[(2, 0)] = 7.0; // output 2, input 0: third value of column 0
    /// assert_eq!(d.params()[0][2], 7.0);
    /// assert_eq!(d.params()[1].len(), 3);
    /// ```
    pub fn params(&self) -> [&[f32]; 2] {
        [self.w.as_slice(), self.b.as_slice()]
    }

    /// The parameters as mutable slices, in the same order as [`Dense::params`].
    pub fn params_mut(&mut self) -> [&mut [f32]; 2] {
        [self.w.as_mut_slice(), self.b.as_mut_slice()]
    }
}

/// Everything after the first layer's pre-activation: `L` hidden `H → H` layers and the output
/// layer `H → O`, all with one hidden activation.
///
/// The first layer is kept outside so the critic can take its observation and action inputs
/// through one layer without const-generic arithmetic (`S + A` is not a stable const expression).
#[derive(Clone, Debug, PartialEq)]
pub struct Trunk<const H: usize, const L: usize, const O: usize> {
    /// Activation after every hidden layer.
    pub activation: Activation,
    /// Hidden-to-hidden layers.
    pub hidden: [Dense<H, H>; L],
    /// Output layer (linear).
    pub output: Dense<H, O>,
}

impl<const H: usize, const L: usize, const O: usize> Trunk<H, L, O> {
    /// The all-zero trunk with tanh activations.
    pub const ZERO: Self = Self {
        activation: Activation::Tanh,
        hidden: [Dense::ZERO; L],
        output: Dense::ZERO,
    };

    /// Runs the trunk on the first layer's pre-activation; returns the linear output.
    ///
    /// ```
    /// use nalgebra::SVector;
    /// use policy_core::{Activation, Trunk};
    /// let mut t = Trunk::<2, 0, 1>::ZERO;
    /// t.activation = Activation::Relu;
    /// t.output.w[(0, 0)] = 1.0;
    /// t.output.w[(0, 1)] = 1.0;
    /// assert_eq!(t.run(SVector::from([3.0, -2.0]))[0], 3.0); // relu(-2) = 0
    /// ```
    ///
    /// Two `H`-vectors live on the stack whatever the depth, so stack use is bounded by the
    /// width alone.
    #[inline]
    pub fn run(&self, mut pre: SVector<f32, H>) -> SVector<f32, O> {
        for layer in &self.hidden {
            let act = self.activate(&pre);
            pre = layer.b;
            layer.accumulate(act.as_slice(), &mut pre);
        }
        let act = self.activate(&pre);
        let mut out = self.output.b;
        self.output.accumulate(act.as_slice(), &mut out);
        out
    }

    /// The hidden activation of a whole layer ([`activate`], as the runtime model applies it).
    #[inline]
    fn activate(&self, pre: &SVector<f32, H>) -> SVector<f32, H> {
        let mut out = *pre;
        activate(self.activation, out.as_mut_slice());
        out
    }

    /// Visits every parameter slice in blob order.
    pub fn params<'a>(&'a self, f: &mut dyn FnMut(&'a [f32])) {
        for layer in &self.hidden {
            layer.params().into_iter().for_each(&mut *f);
        }
        self.output.params().into_iter().for_each(f);
    }

    /// Visits every parameter slice mutably, in the order of [`Trunk::params`].
    pub fn params_mut(&mut self, f: &mut dyn FnMut(&mut [f32])) {
        for layer in &mut self.hidden {
            layer.params_mut().into_iter().for_each(&mut *f);
        }
        self.output.params_mut().into_iter().for_each(f);
    }
}
