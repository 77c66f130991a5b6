//! The badminton scenario: every constant of the game as data (`scenarios/badminton.toml`).
//!
//! Validated like the navigation scenarios: unknown keys, wrong types, and non-finite or
//! out-of-range values are refused with one line naming the file, the line and the key.
//!
//! ```
//! use firmware_sim::badminton::Config;
//! let c = Config::builtin();
//! assert_eq!((c.court.half_length, c.player.catch_radius, c.rules.rally_cap), (6.7, 1.3, 50));
//! let text = Config::BUILTIN.replace("catch_radius = 1.3", "catch_radius = nan");
//! let err = Config::from_toml_str(&text, "b.toml").unwrap_err().to_string();
//! assert!(err.starts_with("b.toml:23: player.catch_radius: must be"), "{err}");
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::number;
use crate::error::parse_error;
use crate::Error;

/// The whole game.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// Name used in reports.
    pub name: String,
    /// One line for humans.
    #[serde(default)]
    pub description: String,
    /// Court and net.
    pub court: CourtConfig,
    /// Shuttle physics.
    pub shuttle: ShuttleConfig,
    /// Players' motion and reach.
    pub player: PlayerConfig,
    /// The ranges the serve agent's actions map onto.
    pub hit: HitConfig,
    /// Rally cap and game rules.
    pub rules: RulesConfig,
    /// The `scripted` reference player.
    pub scripted: ScriptedConfig,
    /// What `firmware-sim match` requires.
    pub pass: MatchPass,
}

/// Court and net, in metres.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CourtConfig {
    /// The court is `x ∈ [-half_length, half_length]` (6.7).
    pub half_length: f64,
    /// The court is `y ∈ [-half_width, half_width]` (2.59).
    pub half_width: f64,
    /// The net is the plane `x = 0` up to this height (1.55).
    pub net_height: f64,
}

/// Shuttle physics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ShuttleConfig {
    /// Gravity, m/s² (9.81).
    pub gravity: f64,
    /// Terminal speed, m/s (6.8); the drag is `gravity / terminal_speed²`.
    pub terminal_speed: f64,
    /// Integration step, s (0.001).
    pub dt: f64,
}

/// Players' motion and reach.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlayerConfig {
    /// Speed limit, m/s (4.5).
    pub max_speed: f64,
    /// Height of the hitting point above the player (1.2).
    pub hit_height: f64,
    /// A receiver catches the shuttle within this distance of its hitting point (1.3).
    pub catch_radius: f64,
    /// Where both players start a point, in their own frames (-2, 0).
    #[serde(deserialize_with = "point")]
    pub start: [f64; 2],
}

/// The hit ranges, in m/s and degrees.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HitConfig {
    /// Slowest hit (3).
    pub min_speed: f64,
    /// Fastest hit (77).
    pub max_speed: f64,
    /// Lowest elevation (-30).
    pub min_elevation: f64,
    /// Highest elevation (75).
    pub max_elevation: f64,
    /// Azimuth range `[-max_azimuth, max_azimuth]` from the player's +x' axis (50).
    pub max_azimuth: f64,
}

/// Rally cap and game rules.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RulesConfig {
    /// Hits after which a rally is cut as a let (50).
    pub rally_cap: u32,
    /// Points that win a game with a lead of `lead` (11: "more than 10").
    pub game_points: u32,
    /// The lead needed (2).
    pub lead: u32,
    /// Points that win a game whatever the lead (20).
    pub point_cap: u32,
}

/// The `scripted` reference player.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScriptedConfig {
    /// Standard deviation of the catch target's noise per axis, m (0.4).
    pub catch_noise: f64,
    /// Elevation of the clear, degrees (50).
    pub serve_elevation: f64,
    /// The clear aims this far inside the opponent's back line (1.0).
    pub serve_depth: f64,
    /// ... and this far inside the side line farther from the opponent (0.6).
    pub serve_side: f64,
    /// Standard deviation of the noise on both serve angles, degrees (2).
    pub serve_angle_noise: f64,
    /// Where it moves after its hit, own frame (-3, 0).
    #[serde(deserialize_with = "point")]
    pub reset: [f64; 2],
}

/// The pass criteria of a match, applied to every player that is not `random`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MatchPass {
    /// Against `random`: the smallest share of the non-let points to win (0.9).
    pub min_points_won_vs_random: f64,
    /// The smallest catch success rate over incoming in-balls (0.9).
    pub min_catch_rate: f64,
    /// The largest share of hits that go out or into the net (0.08).
    pub max_serve_error_rate: f64,
    /// The largest share of points cut at the rally cap (0.5), for every match.
    pub max_let_rate: f64,
}

/// A rule broken by a value: the key (`section.name`) and the message.
type Broken = (&'static str, String);

impl Config {
    /// The shipped scenario's text.
    pub const BUILTIN: &'static str = include_str!("../../scenarios/badminton.toml");

    /// The shipped scenario (docs/design.md §3).
    pub fn builtin() -> Config {
        match Self::from_toml_str(Self::BUILTIN, "badminton") {
            Ok(c) => c,
            // The shipped file is checked by a unit test; this arm cannot be reached.
            Err(e) => unreachable!("the shipped badminton.toml is invalid: {e}"),
        }
    }

    /// `"badminton"` (the shipped scenario) or a TOML file path.
    pub fn resolve(name_or_path: &str) -> Result<Config, Error> {
        if name_or_path == "badminton" {
            return Ok(Self::builtin());
        }
        let path = Path::new(name_or_path);
        let text = crate::files::read_config_text(path).map_err(|e| Error::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Parses and validates; `origin` (a file name) starts every error.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Config, Error> {
        let config: Config = toml::from_str(text).map_err(|e| parse_error(&e, text, origin))?;
        config.broken_rule().map_or(Ok(config), |(key, message)| {
            let location = match line_of(text, key) {
                Some(line) => format!("{origin}:{line}"),
                None => origin.to_string(),
            };
            Err(Error::Parse {
                location,
                message: format!("{key}: {message}"),
            })
        })
    }

    /// The scenario as TOML text, which [`Config::from_toml_str`] reads back to the same value
    /// (a trained team records the plant it trained on).
    ///
    /// ```
    /// use firmware_sim::badminton::Config;
    /// let c = Config::builtin();
    /// assert_eq!(Config::from_toml_str(&c.to_toml(), "copy").unwrap(), c);
    /// ```
    pub fn to_toml(&self) -> String {
        // Plain data with string keys always serialises; keep the error visible if not.
        toml::to_string(self)
            .unwrap_or_else(|e| format!("# could not serialise the scenario: {e}\n"))
    }

    /// Checks every rule of a value built in code; the error names the key.
    pub fn validate(&self) -> Result<(), Error> {
        self.broken_rule().map_or(Ok(()), |(key, message)| {
            Err(Error::Invalid {
                scenario: self.name.clone(),
                field: key.into(),
                message,
            })
        })
    }

    /// The drag coefficient `k = g / v_t²` (m⁻¹).
    pub fn drag(&self) -> f64 {
        self.shuttle.gravity / (self.shuttle.terminal_speed * self.shuttle.terminal_speed)
    }

    fn broken_rule(&self) -> Option<Broken> {
        self.court_rules()
            .or_else(|| self.physics_rules())
            .or_else(|| self.player_rules())
            .or_else(|| self.hit_rules())
            .or_else(|| self.game_rules())
            .or_else(|| self.scripted_rules())
            .or_else(|| self.pass_rules())
    }

    fn court_rules(&self) -> Option<Broken> {
        let c = &self.court;
        in_range("court.half_length", c.half_length, 0.0, 100.0, false)
            .or_else(|| in_range("court.half_width", c.half_width, 0.0, 100.0, false))
            .or_else(|| in_range("court.net_height", c.net_height, 0.0, 100.0, false))
    }

    /// The ranges keep every flight short enough to compute: with gravity ≥ 1, a terminal
    /// speed ≤ 100 and hits ≤ 200 m/s, no flight lasts two minutes, i.e. more than 1.2 million
    /// steps at the smallest `dt`. (A gravity of 1e-300 would validate as "positive" and then
    /// never bring a shuttle down.)
    fn physics_rules(&self) -> Option<Broken> {
        let s = &self.shuttle;
        in_range("shuttle.gravity", s.gravity, 1.0, 100.0, true)
            .or_else(|| in_range("shuttle.terminal_speed", s.terminal_speed, 0.5, 100.0, true))
            .or_else(|| in_range("shuttle.dt", s.dt, 1e-4, 0.01, true))
    }

    fn player_rules(&self) -> Option<Broken> {
        let p = &self.player;
        in_range("player.max_speed", p.max_speed, 0.0, 100.0, false)
            .or_else(|| in_range("player.hit_height", p.hit_height, 0.0, 100.0, true))
            .or_else(|| in_range("player.catch_radius", p.catch_radius, 0.0, 100.0, false))
            .or_else(|| self.in_own_half("player.start", p.start))
    }

    fn hit_rules(&self) -> Option<Broken> {
        let h = &self.hit;
        in_range("hit.max_speed", h.max_speed, 0.0, 200.0, false)
            .or_else(|| in_range("hit.min_speed", h.min_speed, 0.0, h.max_speed, false))
            .or_else(|| in_range("hit.max_elevation", h.max_elevation, -90.0, 90.0, false))
            .or_else(|| {
                in_range(
                    "hit.min_elevation",
                    h.min_elevation,
                    -90.0,
                    h.max_elevation,
                    true,
                )
            })
            .or_else(|| in_range("hit.max_azimuth", h.max_azimuth, 0.0, 90.0, true))
            .or_else(|| {
                // Both ends closed above: the box must stay off the poles (±90°), and the error
                // names the key that reaches one.
                (h.max_azimuth >= 90.0).then(|| {
                    (
                        "hit.max_azimuth",
                        format!("must be below 90, found {}", number(h.max_azimuth)),
                    )
                })
            })
            .or_else(|| {
                (h.min_elevation <= -90.0).then(|| {
                    (
                        "hit.min_elevation",
                        format!("must be above -90, found {}", number(h.min_elevation)),
                    )
                })
            })
    }

    fn game_rules(&self) -> Option<Broken> {
        let r = &self.rules;
        let count = |key, v: u32, lo: u32, hi: u32| {
            (!(lo..=hi).contains(&v)).then(|| (key, format!("must be in {lo}..={hi}, found {v}")))
        };
        count("rules.rally_cap", r.rally_cap, 1, 10_000)
            .or_else(|| count("rules.game_points", r.game_points, 1, 1000))
            .or_else(|| count("rules.lead", r.lead, 1, r.game_points))
            .or_else(|| count("rules.point_cap", r.point_cap, r.game_points, 1000))
    }

    fn scripted_rules(&self) -> Option<Broken> {
        let s = &self.scripted;
        let (h, c) = (&self.hit, &self.court);
        in_range("scripted.catch_noise", s.catch_noise, 0.0, 10.0, true)
            .or_else(|| {
                let (lo, hi) = (h.min_elevation.max(0.0), h.max_elevation);
                in_range("scripted.serve_elevation", s.serve_elevation, lo, hi, false)
            })
            .or_else(|| {
                in_range(
                    "scripted.serve_depth",
                    s.serve_depth,
                    0.0,
                    c.half_length,
                    true,
                )
            })
            .or_else(|| in_range("scripted.serve_side", s.serve_side, 0.0, c.half_width, true))
            .or_else(|| {
                in_range(
                    "scripted.serve_angle_noise",
                    s.serve_angle_noise,
                    0.0,
                    90.0,
                    true,
                )
            })
            .or_else(|| self.in_own_half("scripted.reset", s.reset))
    }

    fn pass_rules(&self) -> Option<Broken> {
        let p = &self.pass;
        [
            ("pass.min_points_won_vs_random", p.min_points_won_vs_random),
            ("pass.min_catch_rate", p.min_catch_rate),
            ("pass.max_serve_error_rate", p.max_serve_error_rate),
            ("pass.max_let_rate", p.max_let_rate),
        ]
        .into_iter()
        .find_map(|(key, v)| in_range(key, v, 0.0, 1.0, true))
    }

    fn in_own_half(&self, key: &'static str, p: [f64; 2]) -> Option<Broken> {
        let (l, w) = (self.court.half_length, self.court.half_width);
        let inside =
            p.iter().all(|c| c.is_finite()) && (-l..=0.0).contains(&p[0]) && p[1].abs() <= w;
        (!inside).then(|| {
            (
                key,
                format!("must lie in the own half [-{l}, 0] × [-{w}, {w}], found {p:?}"),
            )
        })
    }
}

/// Exactly two numbers (serde alone would read the first two of a longer array and ignore the
/// rest, as was found for walls).
fn point<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f64; 2], D::Error> {
    let values = Vec::<f64>::deserialize(d)?;
    match values[..] {
        [x, y] => Ok([x, y]),
        _ => Err(serde::de::Error::custom(format!(
            "expected a point [x, y] of two numbers, found {values:?}"
        ))),
    }
}

/// `Some` unless `v` is finite and in `(lo, hi]` (or `[lo, hi]` when `closed`). When the range
/// is empty (its ends come from other keys) the message says so rather than quoting `(50, 50]`.
fn in_range(key: &'static str, v: f64, lo: f64, hi: f64, closed: bool) -> Option<Broken> {
    let above = if closed { v >= lo } else { v > lo };
    let ok = v.is_finite() && above && v <= hi;
    let open = if closed { '[' } else { '(' };
    let empty = if closed { lo > hi } else { lo >= hi };
    let (lo, hi, found) = (number(lo), number(hi), number(v));
    (!ok).then(|| {
        let message = if empty {
            format!(
                "no value fits: the keys it depends on leave an empty range {open}{lo}, {hi}] (found {found})"
            )
        } else {
            format!("must be in {open}{lo}, {hi}], found {found}")
        };
        (key, message)
    })
}

/// The line (from 1) of `section.key` in the TOML text, for errors found after parsing.
fn line_of(text: &str, dotted: &str) -> Option<usize> {
    let (section, key) = dotted.rsplit_once('.').unwrap_or(("", dotted));
    let mut current = String::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            current = name.trim().to_string();
        } else if current == section {
            let found = line.strip_prefix(key).map(str::trim_start);
            if found.is_some_and(|rest| rest.starts_with('=')) {
                return Some(i + 1);
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn refused(from: &str, to: &str) -> String {
        assert!(Config::BUILTIN.contains(from), "{from}");
        let text = Config::BUILTIN.replace(from, to);
        let e = Config::from_toml_str(&text, "court.toml")
            .expect_err(to)
            .to_string();
        assert_eq!(e.lines().count(), 1, "{e}");
        e
    }

    #[test]
    fn the_shipped_scenario_is_design_section_3() {
        let c = Config::builtin();
        assert_eq!(c.name, "badminton");
        assert_eq!((c.court.half_width, c.court.net_height), (2.59, 1.55));
        assert!((c.drag() - 9.81 / 6.8 / 6.8).abs() < 1e-15);
        assert_eq!(
            (c.shuttle.dt, c.player.max_speed, c.player.hit_height),
            (0.001, 4.5, 1.2)
        );
        assert_eq!((c.hit.min_speed, c.hit.max_speed), (3.0, 77.0));
        assert_eq!(
            (c.hit.min_elevation, c.hit.max_elevation, c.hit.max_azimuth),
            (-30.0, 75.0, 50.0)
        );
        assert_eq!(
            (c.rules.game_points, c.rules.lead, c.rules.point_cap),
            (11, 2, 20)
        );
        assert_eq!(c.player.start, [-2.0, 0.0]);
        assert_eq!(c.scripted.reset, [-3.0, 0.0]);
        assert!(c.validate().is_ok());
    }

    #[test]
    fn an_unknown_key_is_named_with_file_and_line() {
        let e = refused("lead = 2", "lead = 2\nleed = 3");
        assert!(e.starts_with("court.toml:") && e.contains("leed"), "{e}");
    }

    #[test]
    fn non_finite_and_out_of_range_values_name_file_line_and_key() {
        for (from, to, key) in [
            ("gravity = 9.81", "gravity = inf", "shuttle.gravity"),
            ("dt = 0.001", "dt = -0.001", "shuttle.dt"),
            ("gravity = 9.81", "gravity = 1e-300", "shuttle.gravity"),
            (
                "terminal_speed = 6.8",
                "terminal_speed = 1e6",
                "shuttle.terminal_speed",
            ),
            ("max_speed = 77.0", "max_speed = 1e4", "hit.max_speed"),
            ("dt = 0.001", "dt = nan", "shuttle.dt"),
            ("half_length = 6.7", "half_length = 0", "court.half_length"),
            ("max_speed = 4.5", "max_speed = 0.0", "player.max_speed"),
            ("min_speed = 3.0", "min_speed = 80.0", "hit.min_speed"),
            (
                "max_elevation = 75.0",
                "max_elevation = 95.0",
                "hit.max_elevation",
            ),
            ("rally_cap = 50", "rally_cap = 0", "rules.rally_cap"),
            ("point_cap = 20", "point_cap = 5", "rules.point_cap"),
            (
                "catch_noise = 0.4",
                "catch_noise = -0.4",
                "scripted.catch_noise",
            ),
            (
                "reset = [-3.0, 0.0]",
                "reset = [3.0, 0.0]",
                "scripted.reset",
            ),
            ("start = [-2.0, 0.0]", "start = [-2.0, 9.0]", "player.start"),
            (
                "max_let_rate = 0.5",
                "max_let_rate = 1.5",
                "pass.max_let_rate",
            ),
        ] {
            let e = refused(from, to);
            let line = Config::BUILTIN
                .replace(from, to)
                .lines()
                .position(|l| l.trim() == to)
                .expect("line")
                + 1;
            assert!(
                e.starts_with(&format!("court.toml:{line}: {key}: must")),
                "{to}: {e}"
            );
        }
    }

    /// Regression: `min_elevation = -90.0` reported `hit.max_azimuth: must be below 90,
    /// found 50`.
    #[test]
    fn a_pole_elevation_names_min_elevation() {
        let e = refused("min_elevation = -30.0", "min_elevation = -90.0");
        assert!(e.contains("hit.min_elevation: must be above -90"), "{e}");
    }

    /// Regression: an empty range read "must be in (50, 50]", and 1e308 printed as a
    /// 309-digit decimal.
    #[test]
    fn empty_ranges_and_huge_numbers_read_plainly() {
        let text = Config::BUILTIN
            .replace("min_elevation = -30.0", "min_elevation = 75.0")
            .replace("serve_elevation = ", "serve_elevation = 75.0 #");
        let e = Config::from_toml_str(&text, "court.toml")
            .expect_err("empty")
            .to_string();
        assert!(e.contains("empty range"), "{e}");
        let e = refused("max_speed = 77.0", "max_speed = 1e308");
        assert!(e.contains("found 1e308"), "{e}");
        assert!(e.len() < 200, "{e}");
    }

    #[test]
    fn a_wrong_type_or_point_size_is_a_one_line_parse_error() {
        let e = refused("rally_cap = 50", "rally_cap = \"fifty\"");
        assert!(
            e.starts_with("court.toml:") && e.contains("rally_cap"),
            "{e}"
        );
        let e = refused("reset = [-3.0, 0.0]", "reset = [-3.0, 0.0, 1.0]");
        assert!(e.contains("reset"), "{e}");
    }
}
