//! Running an [`Encoding::Integer`] actor: the float entry ([`Model::act`] and the other actor
//! methods, which quantise the observation and dequantise the action with a few float
//! operations per component) and the integer entry ([`Model::act_codes_in`], no float at all),
//! both through one integer forward pass ([`IntegerDense`](crate::mlp::integer::IntegerDense)).

use super::Model;
use crate::blob::{self, Encoding, ModelKind};
use crate::error::Error;
use crate::mlp::integer::{observation_code, unit_of_code};
use crate::Activation;

impl Model<'_> {
    /// The integer entry point of an [`Encoding::Integer`] actor: input codes in, unit codes
    /// out, integer arithmetic only, so a chip without an FPU runs it without software floats.
    ///
    /// `codes` are the observation's int8 codes in the blob's input quantisation (what
    /// [`Model::observation_codes`] computes from floats, or a sensor pipeline that produces
    /// them directly); `scratch` holds two vectors of `W = scratch.len() / 2` integers, `W` at
    /// least [`Model::scratch_width`]; `unit_codes` receives one code per action dimension, in
    /// `-127..=127`: the actuator's command `u = code / 127` of the unit box, which
    /// [`Model::act`] maps onto `[low, high]`. The same integers as [`Model::act`] computes.
    ///
    /// ```
    /// use policy_core::model::{Model, Scratch};
    /// static BLOB: &[u8] = include_bytes!("../../tests/golden/actor_4x48_integer.postcard");
    /// let model = Model::from_blob(BLOB).unwrap();
    /// let mut codes = [0i8; 2];
    /// model.observation_codes(&[4.0, -2.5], &mut codes).unwrap();
    /// let mut unit = [0i8; 2];
    /// model.act_codes_in(&codes, &mut [0i32; 96], &mut unit).unwrap();
    /// let mut unit_f32 = [0.0f32; 2];
    /// model.act_unit(&[4.0, -2.5], &mut Scratch::<48>::new(), &mut unit_f32).unwrap();
    /// assert_eq!(unit_f32, unit.map(|c| f32::from(c) / 127.0));
    /// ```
    pub fn act_codes_in(
        &self,
        codes: &[i8],
        scratch: &mut [i32],
        unit_codes: &mut [i8],
    ) -> Result<(), Error> {
        self.check_integer_actor()?;
        let (x, y) = self.split_integer(codes.len(), unit_codes.len(), scratch)?;
        for (xi, &c) in x.iter_mut().zip(codes) {
            *xi = i32::from(c);
        }
        for (u, &c) in unit_codes.iter_mut().zip(self.integer_forward(x, y)) {
            // Table entries are checked to lie in -127..=127.
            *u = c.clamp(-127, 127) as i8;
        }
        Ok(())
    }

    /// The float entry's input quantisation: each observation component's int8 code (the
    /// normaliser and the first layer's input quantisation folded into `round(x · scale +
    /// offset)`, clamped to int8; a non-finite component gives the code of a normalised 0).
    /// For an [`Encoding::Integer`] actor only.
    pub fn observation_codes(&self, obs: &[f32], codes: &mut [i8]) -> Result<(), Error> {
        self.check_integer_actor()?;
        let s = self.layout.observations;
        for (what, found) in [("observation size", obs.len()), ("code count", codes.len())] {
            if found != s {
                return Err(Error::SizeMismatch {
                    what,
                    expected: found,
                    found: s,
                });
            }
        }
        let (scales, offsets, zero) = self.input_quantisation();
        let maps = scales.iter().zip(offsets.iter());
        for ((c, &x), (scale, offset)) in codes.iter_mut().zip(obs).zip(maps) {
            *c = observation_code(x, scale, offset, zero) as i8;
        }
        Ok(())
    }

    /// [`Model::act_unit_in`] for an integer actor: quantise, run the integer pass, then
    /// `u = code / 127`. The scratch's floats are used as integers (the same size).
    pub(super) fn act_unit_integer(
        &self,
        obs: &[f32],
        scratch: &mut [f32],
        unit: &mut [f32],
    ) -> Result<(), Error> {
        let ints: &mut [i32] = bytemuck::cast_slice_mut(scratch);
        let (x, y) = self.split_integer(obs.len(), unit.len(), ints)?;
        let (scales, offsets, zero) = self.input_quantisation();
        let maps = scales.iter().zip(offsets.iter());
        for ((xi, &o), (scale, offset)) in x.iter_mut().zip(obs).zip(maps) {
            *xi = observation_code(o, scale, offset, zero);
        }
        for (u, &c) in unit.iter_mut().zip(self.integer_forward(x, y)) {
            *u = unit_of_code(c);
        }
        Ok(())
    }

    fn check_integer_actor(&self) -> Result<(), Error> {
        if self.header.kind != ModelKind::Actor {
            return Err(self.wrong_kind(ModelKind::Actor));
        }
        if self.header.encoding != Encoding::Integer {
            return Err(Error::WrongEncoding {
                expected: Encoding::Integer,
                found: self.header.encoding,
            });
        }
        Ok(())
    }

    /// [`Model::split_checked`] for an integer scratch.
    fn split_integer<'s>(
        &self,
        observations: usize,
        actions: usize,
        scratch: &'s mut [i32],
    ) -> Result<(&'s mut [i32], &'s mut [i32]), Error> {
        let width = scratch.len() / 2;
        self.check_io(observations, actions, width)?;
        let (x, rest) = scratch.split_at_mut(width);
        Ok((x, rest.get_mut(..width).unwrap_or_default()))
    }

    /// The input block: scales, offsets (as f32 runs) and the zero point.
    fn input_quantisation(&self) -> (super::Floats<'_>, super::Floats<'_>, i32) {
        let s = self.layout.observations;
        let start = self.layout.layers;
        let part = |from: usize, len: usize| {
            super::Floats(self.payload.get(from..from + 4 * len).unwrap_or_default())
        };
        let zero = self
            .payload
            .get(start + 8 * s..start + 8 * s + 4)
            .and_then(|b| <[u8; 4]>::try_from(b).ok())
            .map_or(0, i32::from_le_bytes);
        (part(start, s), part(start + 4 * s, s), zero)
    }

    /// Every layer from the input codes in `x[..inputs]`; returns the output layer's unit codes.
    fn integer_forward<'s>(&self, mut x: &'s mut [i32], mut y: &'s mut [i32]) -> &'s [i32] {
        let (_, _, mut x_zero) = self.input_quantisation();
        let h = &self.header;
        let relu = h.activation == Activation::Relu;
        let mut outputs = 0;
        blob::integer_layers(h.kind, h.shape, h.activation, |_, layer| {
            let dense = layer.dense(self.payload, relu);
            // The input vector is the working space of the pass's kernel (the next layer
            // writes its outputs there anyway): no scratch beyond the two vectors.
            let xs = x.get_mut(..layer.inputs).unwrap_or_default();
            dense.run_in_place(xs, x_zero, y.get_mut(..layer.outputs).unwrap_or_default());
            x_zero = if layer.table.is_some() {
                0
            } else {
                dense.output_zero
            };
            outputs = layer.outputs;
            core::mem::swap(&mut x, &mut y);
        });
        // After the last swap the output layer's codes are in `x`.
        x.get(..outputs).unwrap_or_default()
    }
}
