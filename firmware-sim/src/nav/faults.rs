//! The faults of navigation's test protocol: sensor dropouts and a stuck actuator (the firmware
//! loop's own faults, defined with the sensor and the actuator) and a wall that appears or moves
//! during the episode (the navigation plant's).
//!
//! Faults are written as a comma-separated list (the CLI's `--faults`):
//!
//! | item                      | meaning                                                        |
//! |---------------------------|----------------------------------------------------------------|
//! | `dropout-nan:P`           | each tick, with probability P, the sensor reads NaN            |
//! | `dropout-stale:P`         | each tick, with probability P, the sensor repeats its last value |
//! | `stuck:D@T`               | from tick T on, actuator dimension D holds its last output     |
//! | `wall:T@X0/Y0/X1/Y1`      | at tick T a wall from (X0, Y0) to (X1, Y1) appears             |
//! | `wall:T@X0/Y0/X1/Y1@I`    | at tick T wall number I of the scenario moves there            |
//!
//! At most one fault of each kind per run: one dropout (`dropout-nan` or `dropout-stale`, they
//! share the sensor), one stuck actuator, one wall change. A kind given twice is an error
//! rather than the last one silently winning.
//!
//! ```
//! use firmware_sim::nav::faults::Faults;
//! use firmware_sim::sensor::DropoutMode;
//! let f: Faults = "dropout-nan:0.1,stuck:0@50,wall:20@-2/0/2/0".parse().unwrap();
//! assert_eq!(f.dropout.unwrap().mode, DropoutMode::Nan);
//! assert_eq!(f.stuck.unwrap().from_tick, 50);
//! assert_eq!(f.wall.unwrap().wall.to, [2.0, 0.0]);
//! assert!("stuck:x@3".parse::<Faults>().is_err());
//! let twice = "wall:0@-2/1/2/1,wall:0@-2/-1/2/-1".parse::<Faults>().unwrap_err();
//! assert!(twice.to_string().contains("given twice"), "{twice}");
//! ```

use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::actuator::ActuatorStuck;
use crate::nav::scenario::{Scenario, Wall};
use crate::sensor::{Dropout, DropoutMode};
use crate::Error;

/// Every fault of one evaluation (none by default).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Faults {
    /// Sensor dropouts.
    pub dropout: Option<Dropout>,
    /// An actuator dimension that freezes.
    pub stuck: Option<ActuatorStuck>,
    /// A wall that appears or moves.
    pub wall: Option<WallChange>,
}

/// At `at_tick`, `wall` appears (or replaces the scenario's wall number `replaces`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct WallChange {
    /// Tick (0-based) before whose step the change happens.
    pub at_tick: u32,
    /// The new wall.
    pub wall: Wall,
    /// Index of the scenario wall it replaces (moves), or `None` to add it.
    pub replaces: Option<usize>,
}

impl Faults {
    /// Checks the faults against the plant: probabilities, dimensions, wall positions.
    ///
    /// ```
    /// use firmware_sim::nav::faults::Faults;
    /// use firmware_sim::nav::scenario::Scenario;
    /// let s = Scenario::builtin("nav-walls").unwrap();
    /// let ok: Faults = "wall:10@-1/-3/1/-3@8".parse().unwrap();
    /// assert!(ok.validate(&s, 2).is_ok());
    /// assert_eq!(ok.changed_walls(&s).unwrap()[8].from, [-1.0, -3.0]);
    /// let outside: Faults = "wall:10@0/0/0/9".parse().unwrap();
    /// assert!(outside.validate(&s, 2).unwrap_err().to_string().contains("outside the arena"));
    /// ```
    pub fn validate(&self, scenario: &Scenario, actions: usize) -> Result<(), Error> {
        crate::firmware::validate_faults(self.dropout, self.stuck, actions)?;
        if let Some(w) = self.wall {
            let mut changed = scenario.clone();
            match w.replaces {
                Some(i) if i >= scenario.walls.len() => {
                    return Err(bad(format!(
                        "wall to move must be below {}, found {i}",
                        scenario.walls.len()
                    )))
                }
                Some(i) => changed.walls[i] = w.wall,
                None => changed.walls.push(w.wall),
            }
            changed
                .validate()
                .map_err(|e| bad(format!("the changed wall is invalid: {e}")))?;
        }
        Ok(())
    }

    /// The scenario's walls after the wall change.
    pub fn changed_walls(&self, scenario: &Scenario) -> Option<Vec<Wall>> {
        let w = self.wall?;
        let mut walls = scenario.walls.clone();
        match w.replaces {
            Some(i) => *walls.get_mut(i)? = w.wall,
            None => walls.push(w.wall),
        }
        Some(walls)
    }
}

fn bad(message: String) -> Error {
    Error::Config {
        field: "faults",
        message,
    }
}

impl FromStr for Faults {
    type Err = Error;

    fn from_str(spec: &str) -> Result<Faults, Error> {
        let mut faults = Faults::default();
        // The item that set each kind, to name both in the error when one comes again.
        let mut seen: [Option<&str>; 3] = [None; 3];
        for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (kind, arg) = item.split_once(':').ok_or_else(|| unknown(item))?;
            let slot = match kind {
                "dropout-nan" | "dropout-stale" => 0,
                "stuck" => 1,
                "wall" => 2,
                _ => return Err(unknown(item)),
            };
            if let Some(first) = seen[slot].replace(item) {
                return Err(twice(first, item));
            }
            match slot {
                0 => faults.dropout = Some(parse_dropout(kind, arg, item)?),
                1 => faults.stuck = Some(parse_stuck(arg, item)?),
                _ => faults.wall = Some(parse_wall(arg, item)?),
            }
        }
        Ok(faults)
    }
}

fn twice(first: &str, again: &str) -> Error {
    bad(format!(
        "{first:?} and {again:?}: a fault kind given twice; at most one of each kind per run \
         (one dropout-nan or dropout-stale, one stuck, one wall)"
    ))
}

fn parse_dropout(kind: &str, arg: &str, item: &str) -> Result<Dropout, Error> {
    let mode = if kind == "dropout-nan" {
        DropoutMode::Nan
    } else {
        DropoutMode::Stale
    };
    Ok(Dropout {
        probability: number(arg, item, "a probability P in [0, 1]")?,
        mode,
    })
}

fn parse_stuck(arg: &str, item: &str) -> Result<ActuatorStuck, Error> {
    let (dim, tick) = arg.split_once('@').ok_or_else(|| unknown(item))?;
    Ok(ActuatorStuck {
        dim: number(dim, item, "an action dimension D such as 0")?,
        from_tick: number(tick, item, "a tick T such as 40")?,
    })
}

fn parse_wall(arg: &str, item: &str) -> Result<WallChange, Error> {
    let mut parts = arg.split('@');
    let at_tick = number(parts.next().unwrap_or(""), item, "a tick T such as 40")?;
    let coords: Vec<f64> = parts
        .next()
        .unwrap_or("")
        .split('/')
        .map(|c| number(c, item, "a coordinate such as -1.5"))
        .collect::<Result<_, _>>()?;
    let [x0, y0, x1, y1] = coords[..] else {
        return Err(unknown(item));
    };
    let replaces = parts
        .next()
        .map(|i| number(i, item, "a wall index I such as 3"))
        .transpose()?;
    if parts.next().is_some() {
        return Err(unknown(item));
    }
    Ok(WallChange {
        at_tick,
        wall: Wall {
            from: [x0, y0],
            to: [x1, y1],
        },
        replaces,
    })
}

/// One number of a fault; the error says what was expected there.
fn number<T: FromStr>(text: &str, item: &str, expected: &str) -> Result<T, Error> {
    text.trim().parse().map_err(|_| {
        bad(format!(
            "cannot read {text:?} in fault {item:?}: expected {expected}"
        ))
    })
}

fn unknown(item: &str) -> Error {
    bad(format!(
        "unknown fault {item:?}: expected dropout-nan:P, dropout-stale:P, stuck:D@T, wall:T@X0/Y0/X1/Y1[@I]"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: `wall:…,wall:…,dropout-nan:1,dropout-stale:0` was accepted
    /// and only the last wall and the last dropout applied. A kind given twice is refused, and
    /// the two dropout modes share one slot.
    #[test]
    fn a_fault_kind_given_twice_is_refused_naming_both_items() {
        for (spec, first, again) in [
            (
                "wall:0@-2/1/2/1,wall:0@-2/-1/2/-1",
                "wall:0@-2/1/2/1",
                "wall:0@-2/-1/2/-1",
            ),
            (
                "dropout-nan:1,dropout-stale:0",
                "dropout-nan:1",
                "dropout-stale:0",
            ),
            (
                "dropout-nan:0.1, stuck:0@3, dropout-nan:0.2",
                "dropout-nan:0.1",
                "dropout-nan:0.2",
            ),
            ("stuck:0@3,stuck:1@5", "stuck:0@3", "stuck:1@5"),
        ] {
            let e = spec.parse::<Faults>().expect_err(spec).to_string();
            assert!(e.starts_with("faults:") && e.contains("given twice"), "{e}");
            assert!(
                e.contains(&format!("{first:?}")) && e.contains(&format!("{again:?}")),
                "{e}"
            );
            assert!(!e.contains('\n'), "{e}");
        }
        let one_of_each: Faults = "dropout-stale:0.1,stuck:1@4,wall:2@-1/0/1/0"
            .parse()
            .expect("one of each kind");
        assert!(one_of_each.dropout.is_some() && one_of_each.stuck.is_some());
        assert!(one_of_each.wall.is_some());
    }
}
