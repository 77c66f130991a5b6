//! The firmware's side of the loop, whatever the plant: every tick the sensor reads the plant's
//! true observation (noise, quantisation, delay, dropouts), the controller acts (timed), and the
//! actuator sanitises and saturates the command (rate limit, stuck fault) before the plant sees
//! it.

use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::actuator::{Actuator, ActuatorModel, ActuatorStuck};
use crate::controller::Controller;
use crate::env::BoxSpace;
use crate::error::number;
use crate::seed::stream;
use crate::sensor::{Dropout, Sensor, SensorModel};
use crate::Error;

/// Inference time per tick (wall-clock; the only part of a report that is not deterministic).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timing {
    /// Mean nanoseconds per `act` call.
    pub mean_ns: f64,
    /// Slowest `act` call, in nanoseconds.
    pub worst_ns: u64,
}

/// Wall-clock statistics of the `act` calls.
#[derive(Debug, Default)]
pub(crate) struct Clock {
    total_ns: u128,
    calls: u64,
    worst_ns: u64,
}

impl Clock {
    pub(crate) fn add(&mut self, ns: u128) {
        self.total_ns += ns;
        self.calls += 1;
        self.worst_ns = self.worst_ns.max(u64::try_from(ns).unwrap_or(u64::MAX));
    }

    pub(crate) fn timing(&self) -> Timing {
        let mean_ns = if self.calls == 0 {
            0.0
        } else {
            self.total_ns as f64 / self.calls as f64
        };
        Timing {
            mean_ns,
            worst_ns: self.worst_ns,
        }
    }
}

/// The firmware's side of the loop for one episode: sensor in, controller, actuator out.
pub(crate) struct Firmware {
    sensor: Sensor,
    actuator: Actuator,
    command: Vec<f32>,
    action: Vec<f32>,
    high: Vec<f32>,
}

impl Firmware {
    /// The firmware of episode `index` of a run seeded `seed`, for a plant whose action box is
    /// `space`: the sensor's noise and dropout streams are that episode's.
    pub(crate) fn new(
        space: &BoxSpace,
        sensor: SensorModel,
        actuator: ActuatorModel,
        dropout: Option<Dropout>,
        stuck: Option<ActuatorStuck>,
        seed: u64,
        index: u64,
    ) -> Self {
        let noise = stream(seed, "sensor-noise", index);
        let drops = stream(seed, "sensor-dropout", index);
        Firmware {
            sensor: Sensor::new(sensor, dropout, noise, drops),
            actuator: Actuator::new(&space.low, &space.high, actuator, stuck),
            command: vec![0.0; space.dim()],
            action: vec![0.0; space.dim()],
            high: space.high.clone(),
        }
    }

    /// One control period: read the sensor, call the controller (timed), drive the actuator.
    /// Returns what the plant receives: always finite and inside the action box.
    pub(crate) fn control(
        &mut self,
        tick: u32,
        truth: &[f32],
        controller: &mut dyn Controller,
        clock: &mut Clock,
        saturated: &mut [u32],
    ) -> &[f32] {
        let obs = self.sensor.read(truth);
        let t0 = Instant::now();
        controller.act(&obs, &mut self.command);
        clock.add(t0.elapsed().as_nanos());
        count_saturated(&self.command, &self.high, saturated);
        self.actuator.drive(tick, &self.command, &mut self.action);
        if !self.actuator.in_bounds(&self.action) {
            // Unreachable by construction of `drive`; kept so nothing unsafe ever reaches the
            // plant even if the actuator model changes.
            self.action.fill(0.0);
        }
        &self.action
    }

    /// Commands that were NaN or infinite and that the actuator replaced by 0.
    pub(crate) fn sanitized(&self) -> u64 {
        self.actuator.sanitized
    }
}

/// A command component is saturated when it is at or beyond the box bound (or not finite).
fn count_saturated(command: &[f32], high: &[f32], counts: &mut [u32]) {
    for ((c, h), n) in command.iter().zip(high).zip(counts.iter_mut()) {
        if !c.is_finite() || c.abs() >= h * (1.0 - 1e-6) {
            *n += 1;
        }
    }
}

/// Checks a sensor and an actuator model: noise and quantum finite and `>= 0`, a rate limit
/// finite and `> 0`.
pub(crate) fn validate_models(s: &SensorModel, a: &ActuatorModel) -> Result<(), Error> {
    let bad = |field, message| Err(Error::Config { field, message });
    if !(s.noise_std.is_finite() && s.noise_std >= 0.0) {
        return bad(
            "sensor.noise_std",
            format!("must be finite and >= 0, found {}", number(s.noise_std)),
        );
    }
    if !(s.quantum.is_finite() && s.quantum >= 0.0) {
        return bad(
            "sensor.quantum",
            format!("must be finite and >= 0, found {}", number(s.quantum)),
        );
    }
    if let Some(r) = a.rate_limit {
        if !(r.is_finite() && r > 0.0) {
            return bad(
                "actuator.rate_limit",
                format!("must be finite and > 0, found {}", number(r)),
            );
        }
    }
    Ok(())
}

/// Checks the faults every plant has: a dropout probability in `[0, 1]`, a stuck dimension
/// below the plant's `actions`.
pub(crate) fn validate_faults(
    dropout: Option<Dropout>,
    stuck: Option<ActuatorStuck>,
    actions: usize,
) -> Result<(), Error> {
    let bad = |message| {
        Err(Error::Config {
            field: "faults",
            message,
        })
    };
    if let Some(d) = dropout {
        if !(0.0..=1.0).contains(&d.probability) {
            return bad(format!(
                "dropout probability must be in [0, 1], found {}",
                number(d.probability)
            ));
        }
    }
    if let Some(s) = stuck {
        if s.dim >= actions {
            return bad(format!(
                "stuck dimension must be below {actions}, found {}",
                s.dim
            ));
        }
    }
    Ok(())
}
