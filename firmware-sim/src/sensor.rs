//! The position sensor of the firmware loop: noise, quantisation, a one-tick delay, dropouts.

use serde::{Deserialize, Serialize};

use crate::seed::{normal, uniform, SimRng};

/// Sensor dropouts: each tick, independently, the reading is lost with `probability`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Dropout {
    /// Chance per tick, in `[0, 1]`.
    pub probability: f64,
    /// What the firmware reads instead.
    pub mode: DropoutMode,
}

/// What a lost sensor reading looks like to the firmware.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DropoutMode {
    /// Every component is NaN.
    Nan,
    /// The previous reading, again.
    Stale,
}

/// How the sensor distorts the true observation (ideal by default, like the trainer's plant).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SensorModel {
    /// Standard deviation of additive Gaussian noise (0 = none).
    pub noise_std: f32,
    /// Quantisation step: readings are rounded to multiples of it (0 = none).
    pub quantum: f32,
    /// Deliver the previous tick's reading (a one-tick delay).
    pub delay: bool,
}

/// A sensor in use during one episode.
#[derive(Debug)]
pub(crate) struct Sensor {
    model: SensorModel,
    dropout: Option<Dropout>,
    noise: SimRng,
    drops: SimRng,
    pending: Option<Vec<f32>>,
    last: Option<Vec<f32>>,
}

impl Sensor {
    pub(crate) fn new(
        model: SensorModel,
        dropout: Option<Dropout>,
        noise: SimRng,
        drops: SimRng,
    ) -> Self {
        Self {
            model,
            dropout,
            noise,
            drops,
            pending: None,
            last: None,
        }
    }

    /// What the firmware reads this tick when the truth is `truth`.
    pub(crate) fn read(&mut self, truth: &[f32]) -> Vec<f32> {
        let measured: Vec<f32> = truth.iter().map(|&x| self.measure(x)).collect();
        let mut out = if self.model.delay {
            self.pending.replace(measured.clone()).unwrap_or(measured)
        } else {
            measured
        };
        if let Some(d) = self.dropout {
            // Drawn every tick, dropped or not, so the streams stay aligned across settings.
            if uniform(&mut self.drops) < d.probability {
                out = match (d.mode, &self.last) {
                    (DropoutMode::Nan, _) => vec![f32::NAN; truth.len()],
                    (DropoutMode::Stale, Some(last)) => last.clone(),
                    (DropoutMode::Stale, None) => out,
                };
            }
        }
        self.last = Some(out.clone());
        out
    }

    fn measure(&mut self, x: f32) -> f32 {
        let mut v = x;
        if self.model.noise_std > 0.0 {
            v += (normal(&mut self.noise) * f64::from(self.model.noise_std)) as f32;
        }
        if self.model.quantum > 0.0 {
            v = (v / self.model.quantum).round() * self.model.quantum;
        }
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::stream;

    fn sensor(model: SensorModel, dropout: Option<Dropout>) -> Sensor {
        Sensor::new(model, dropout, stream(0, "noise", 0), stream(0, "drops", 0))
    }

    #[test]
    fn delay_delivers_the_previous_reading() {
        let mut s = sensor(
            SensorModel {
                delay: true,
                ..SensorModel::default()
            },
            None,
        );
        assert_eq!(s.read(&[1.0, 2.0]), vec![1.0, 2.0]); // nothing older yet
        assert_eq!(s.read(&[3.0, 4.0]), vec![1.0, 2.0]);
        assert_eq!(s.read(&[5.0, 6.0]), vec![3.0, 4.0]);
    }

    #[test]
    fn quantisation_rounds_to_the_step() {
        let mut s = sensor(
            SensorModel {
                quantum: 0.5,
                ..SensorModel::default()
            },
            None,
        );
        assert_eq!(s.read(&[1.3, -0.7]), vec![1.5, -0.5]);
    }

    #[test]
    fn noise_has_the_configured_spread() {
        let mut s = sensor(
            SensorModel {
                noise_std: 0.1,
                ..SensorModel::default()
            },
            None,
        );
        let n = 4000;
        let var = (0..n)
            .map(|_| f64::from(s.read(&[0.0])[0]).powi(2))
            .sum::<f64>()
            / f64::from(n);
        assert!((var.sqrt() - 0.1).abs() < 0.01, "{}", var.sqrt());
    }

    #[test]
    fn dropouts_give_nan_or_the_stale_reading() {
        let all = |mode| {
            Some(Dropout {
                probability: 1.0,
                mode,
            })
        };
        let mut nan = sensor(SensorModel::default(), all(DropoutMode::Nan));
        assert!(nan.read(&[1.0, 2.0]).iter().all(|v| v.is_nan()));
        let mut stale = sensor(SensorModel::default(), all(DropoutMode::Stale));
        assert_eq!(stale.read(&[1.0, 2.0]), vec![1.0, 2.0]);
        assert_eq!(stale.read(&[3.0, 4.0]), vec![1.0, 2.0]);
    }
}
