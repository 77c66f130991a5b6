//! Scenarios: the navigation task as data (arena, walls, starts, reward, limits, pass criteria).
//!
//! A scenario is a TOML file. Unknown keys are errors (a misspelt `time_limt` must not silently
//! fall back to a default), and every value is checked before a plant is built from it. The two
//! layouts of experiment 1 ship with the crate: `nav-walls` (the pinwheel, default) and
//! `nav-open` (no walls).
//!
//! ```
//! use firmware_sim::nav::Reward;
//! use firmware_sim::nav::scenario::Scenario;
//! let mut s = Scenario::builtin("nav-walls").unwrap();
//! assert_eq!((s.arena_half_size, s.max_step, s.time_limit), (6.0, 0.25, 200));
//! assert_eq!(s.walls.len(), 13);
//! s.reward = Reward::Gr; // the trainer picks the reward form
//! let err = Scenario::from_toml_str("name = \"x\"\ntime_limt = 3\n").expect_err("must be refused");
//! assert!(err.to_string().contains("time_limt"), "{err}");
//! ```

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::geometry::{Segment, Vec2};
use super::reward::Reward;
use crate::error::{number, parse_error};
use crate::Error;

/// The default scenario: the pinwheel of docs/design.md §2.
pub const DEFAULT_SCENARIO: &str = "nav-walls";

/// The largest arena half-size: a million units, far beyond any plant here, and small enough that
/// every position in the arena is a finite `f32` with room to spare.
pub const MAX_ARENA_HALF_SIZE: f64 = 1e6;

/// The longest episode a scenario may ask for, in ticks (100,000: 500 times the shipped
/// scenarios' 200). A test runs the full time limit, so a typo such as `time_limit =
/// 4294967295` would otherwise run for hours.
pub const MAX_TIME_LIMIT: u32 = 100_000;

/// Names accepted by [`Scenario::builtin`].
pub const BUILTIN_NAMES: [&str; 2] = ["nav-walls", "nav-open"];

const NAV_WALLS: &str = include_str!("../../scenarios/nav-walls.toml");
const NAV_OPEN: &str = include_str!("../../scenarios/nav-open.toml");

/// One navigation task.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name used in reports.
    pub name: String,
    /// One line for humans.
    #[serde(default)]
    pub description: String,
    /// The arena is the square `[-h, h]²`; crossing its boundary ends the episode.
    pub arena_half_size: f64,
    /// Largest step per axis: the action box is `[-max_step, max_step]²` (0.25).
    pub max_step: f32,
    /// The reward form (LR, GR or LR+GR); the trainer may change it before building a plant.
    pub reward: Reward,
    /// Discount used for the exit penalty `worst / (1 - gamma)` (0.99).
    pub gamma: f32,
    /// Steps before truncation (200), at most [`MAX_TIME_LIMIT`].
    pub time_limit: u32,
    /// The goal is the centre; within this distance counts as there (0.1).
    pub goal_radius: f64,
    /// Consecutive steps within `goal_radius` that reach the goal (10).
    pub goal_hold: u32,
    /// Where episodes start.
    pub start: StartRule,
    /// Thresholds of the test metrics.
    #[serde(default)]
    pub metrics: Metrics,
    /// What `firmware-sim run` requires to exit with success.
    pub pass: PassCriteria,
    /// Zero-thickness walls.
    #[serde(default, deserialize_with = "deserialize_walls")]
    pub walls: Vec<Wall>,
}

/// How an episode's start point is drawn from its seed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "kebab-case", deny_unknown_fields)]
pub enum StartRule {
    /// A uniform point on the arena boundary, moved `inset` inside it (docs/design.md §2: one step, 0.25).
    Boundary {
        /// Distance inside the boundary.
        inset: f64,
    },
    /// One of these points, chosen uniformly.
    Points {
        /// Candidate start points.
        points: Vec<[f64; 2]>,
    },
}

/// Thresholds of the test metrics (docs/design.md §2 and the stuck-at-margin rule).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Metrics {
    /// Steps at the end of a test whose mean position is where the agent settled (20).
    pub settle_window: u32,
    /// A test succeeds when every one of those positions is within this of the centre (2).
    pub success_radius: f64,
    /// A test "passes near" the centre when it comes within this distance (0.25).
    pub near_radius: f64,
    /// Steps of pushing without progress while touching a wall that make an episode stuck (20).
    pub stuck_window: u32,
    /// Pushing means a commanded step of at least this fraction of `max_step` (0.5).
    pub stuck_min_command: f32,
    /// No progress means moving less than this over the window (0.05).
    pub stuck_max_progress: f64,
}

impl Metrics {
    /// docs/design.md §2's success rule on the distances from the centre over an episode's last
    /// `settle_window` steps: there is at least one, and every one is within `success_radius`.
    /// firmware-sim's test metrics and the trainer's training-success column both ask it.
    ///
    /// ```
    /// let m = firmware_sim::nav::scenario::Metrics::default();
    /// assert!(m.settled([0.5, 2.0, 1.0]));
    /// assert!(!m.settled([0.5, 2.01]));
    /// assert!(!m.settled([]));
    /// ```
    pub fn settled(&self, last_distances: impl IntoIterator<Item = f64>) -> bool {
        let mut any = false;
        for d in last_distances {
            if d.is_nan() || d > self.success_radius {
                return false;
            }
            any = true;
        }
        any
    }
}

impl Default for Metrics {
    fn default() -> Self {
        Self {
            settle_window: 20,
            success_radius: 2.0,
            near_radius: 0.25,
            stuck_window: 20,
            stuck_min_command: 0.5,
            stuck_max_progress: 0.05,
        }
    }
}

/// Pass criteria for CI gating.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PassCriteria {
    /// Smallest acceptable success rate, in `[0, 1]`.
    pub min_success_rate: f64,
    /// Largest acceptable stuck-at-margin rate, in `[0, 1]`.
    pub max_stuck_rate: f64,
}

/// A wall segment as written in a scenario: each end is exactly two numbers `[x, y]`.
///
/// ```
/// use firmware_sim::nav::scenario::Wall;
/// let w: Wall = serde_json::from_str(r#"{ "from": [0, 1], "to": [2.5, 1] }"#).unwrap();
/// assert_eq!(w.to, [2.5, 1.0]);
/// let err = serde_json::from_str::<Wall>(r#"{ "from": [0, 1, 7], "to": [2, 1] }"#).unwrap_err();
/// assert!(err.to_string().starts_with("from: expected a point [x, y] of two numbers"), "{err}");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawWall")]
pub struct Wall {
    /// One end.
    pub from: [f64; 2],
    /// The other end.
    pub to: [f64; 2],
}

/// A wall as written, before its points are checked. serde reads `[f64; 2]` from the first two
/// values of a TOML array and silently ignores the rest, so the ends are read as lists of any
/// values and checked here.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWall {
    from: Vec<Coordinate>,
    to: Vec<Coordinate>,
}

impl RawWall {
    /// The wall, or `"FIELD: message"`.
    fn check(self) -> Result<Wall, String> {
        Ok(Wall {
            from: point(&self.from).map_err(|e| format!("from: {e}"))?,
            to: point(&self.to).map_err(|e| format!("to: {e}"))?,
        })
    }
}

impl TryFrom<RawWall> for Wall {
    type Error = String;

    fn try_from(raw: RawWall) -> Result<Wall, String> {
        raw.check()
    }
}

/// Exactly two numbers.
fn point(values: &[Coordinate]) -> Result<[f64; 2], String> {
    match values {
        [Coordinate::Number(x), Coordinate::Number(y)] => Ok([*x, *y]),
        _ => {
            let found: Vec<String> = values.iter().map(Coordinate::to_string).collect();
            Err(format!(
                "expected a point [x, y] of two numbers, found [{}]",
                found.join(", ")
            ))
        }
    }
}

/// The walls, each checked as [`RawWall::check`] does, with the wall's index in the error.
fn deserialize_walls<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<Wall>, D::Error> {
    Vec::<RawWall>::deserialize(d)?
        .into_iter()
        .enumerate()
        .map(|(i, w)| {
            w.check()
                .map_err(|e| serde::de::Error::custom(format!("walls[{i}].{e}")))
        })
        .collect()
}

/// One value of a point as written: a number, or something else (kept to be named in the
/// error).
#[derive(Debug)]
enum Coordinate {
    Number(f64),
    Other(String),
}

impl std::fmt::Display for Coordinate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Coordinate::Number(x) => write!(f, "{x:?}"),
            Coordinate::Other(what) => f.write_str(what),
        }
    }
}

impl<'de> Deserialize<'de> for Coordinate {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(CoordinateVisitor)
    }
}

struct CoordinateVisitor;

impl<'de> serde::de::Visitor<'de> for CoordinateVisitor {
    type Value = Coordinate;

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a number")
    }

    fn visit_f64<E>(self, v: f64) -> Result<Coordinate, E> {
        Ok(Coordinate::Number(v))
    }

    fn visit_i64<E>(self, v: i64) -> Result<Coordinate, E> {
        Ok(Coordinate::Number(v as f64))
    }

    fn visit_u64<E>(self, v: u64) -> Result<Coordinate, E> {
        Ok(Coordinate::Number(v as f64))
    }

    fn visit_bool<E>(self, v: bool) -> Result<Coordinate, E> {
        Ok(Coordinate::Other(v.to_string()))
    }

    fn visit_str<E>(self, v: &str) -> Result<Coordinate, E> {
        Ok(Coordinate::Other(format!("{v:?}")))
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Coordinate, A::Error> {
        while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {}
        Ok(Coordinate::Other("an array".into()))
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Coordinate, A::Error> {
        while map
            .next_entry::<serde::de::IgnoredAny, serde::de::IgnoredAny>()?
            .is_some()
        {}
        Ok(Coordinate::Other("a table".into()))
    }
}

impl Wall {
    /// The wall as a geometry segment.
    pub fn segment(&self) -> Segment {
        Segment::new(
            Vec2::new(self.from[0], self.from[1]),
            Vec2::new(self.to[0], self.to[1]),
        )
    }
}

impl Scenario {
    /// Parses and validates a scenario from TOML text.
    ///
    /// ```
    /// use firmware_sim::nav::scenario::Scenario;
    /// let text = r#"
    /// name = "corridor"
    /// arena_half_size = 3.0
    /// max_step = 0.25
    /// reward = "lr-gr"
    /// gamma = 0.99
    /// time_limit = 100
    /// goal_radius = 0.1
    /// goal_hold = 10
    /// start = { rule = "points", points = [[2.5, 2.5]] }
    /// pass = { min_success_rate = 0.5, max_stuck_rate = 0.5 }
    /// walls = [{ from = [-2.0, 1.0], to = [2.0, 1.0] }]
    /// "#;
    /// let s = Scenario::from_toml_str(text).unwrap();
    /// assert_eq!((s.walls.len(), s.metrics.settle_window), (1, 20));
    /// ```
    pub fn from_toml_str(text: &str) -> Result<Scenario, Error> {
        Self::parse(text, "<string>")
    }

    /// Reads, parses and validates a scenario file; errors name the file, line and column.
    ///
    /// ```
    /// use firmware_sim::nav::scenario::Scenario;
    /// let path = std::env::temp_dir().join("firmware-sim-doc-load.toml");
    /// let text = std::fs::read_to_string("scenarios/nav-open.toml").unwrap();
    /// std::fs::write(&path, text.replace("time_limit = 200", "time_limit = 50")).unwrap();
    /// assert_eq!(Scenario::load(&path).unwrap().time_limit, 50);
    /// std::fs::write(&path, "name = 3").unwrap();
    /// let err = Scenario::load(&path).unwrap_err().to_string();
    /// assert!(err.contains("firmware-sim-doc-load.toml:1:8"), "{err}");
    /// # std::fs::remove_file(&path).unwrap();
    /// ```
    pub fn load(path: &Path) -> Result<Scenario, Error> {
        let text = crate::files::read_config_text(path).map_err(|e| Error::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        Self::parse(&text, &path.display().to_string())
    }

    /// A shipped scenario: `"nav-walls"` (the pinwheel) or `"nav-open"` (no walls).
    pub fn builtin(name: &str) -> Option<Scenario> {
        let text = match name {
            "nav-walls" => NAV_WALLS,
            "nav-open" => NAV_OPEN,
            _ => return None,
        };
        Self::parse(text, name).ok()
    }

    /// A built-in name, else a file path (what the CLI's `--scenario` takes).
    ///
    /// ```
    /// use firmware_sim::nav::scenario::Scenario;
    /// assert_eq!(Scenario::resolve("nav-open").unwrap().name, "nav-open");
    /// let err = Scenario::resolve("nav-mars").unwrap_err().to_string();
    /// assert!(err.contains("nav-mars") && err.contains("nav-walls"), "{err}");
    /// ```
    pub fn resolve(name_or_path: &str) -> Result<Scenario, Error> {
        if let Some(s) = Self::builtin(name_or_path) {
            return Ok(s);
        }
        let path = Path::new(name_or_path);
        if !path.exists() {
            return Err(Error::UnknownScenario {
                name: name_or_path.to_string(),
                builtin: &BUILTIN_NAMES,
            });
        }
        Self::load(path)
    }

    /// The walls as geometry segments.
    ///
    /// ```
    /// use firmware_sim::nav::scenario::Scenario;
    /// let walls = Scenario::builtin("nav-walls").unwrap().segments();
    /// assert_eq!(walls[0].length(), 4.5); // outer south wall, west of its gap
    /// ```
    pub fn segments(&self) -> Vec<Segment> {
        self.walls.iter().map(Wall::segment).collect()
    }

    fn parse(text: &str, origin: &str) -> Result<Scenario, Error> {
        let scenario: Scenario = toml::from_str(text).map_err(|e| parse_error(&e, text, origin))?;
        scenario.validate()?;
        Ok(scenario)
    }

    /// Checks every rule; the error names the field and the value.
    ///
    /// ```
    /// use firmware_sim::nav::scenario::Scenario;
    /// let mut s = Scenario::builtin("nav-walls").unwrap();
    /// s.walls[2].to = [3.5, 8.0];
    /// let err = s.validate().unwrap_err().to_string();
    /// assert!(err.starts_with("scenario nav-walls: walls[2]:"), "{err}");
    /// ```
    pub fn validate(&self) -> Result<(), Error> {
        let h = self.arena_half_size;
        // The plant observes positions as f32: an arena beyond MAX_ARENA_HALF_SIZE would be
        // observed as infinities (a fuzz finding: 1e39 validated, and `reset` saw [inf, inf]).
        self.check(
            h.is_finite() && h > 0.0 && h <= MAX_ARENA_HALF_SIZE,
            "arena_half_size",
            format!(
                "must be in (0, {}], found {}",
                number(MAX_ARENA_HALF_SIZE),
                number(h)
            ),
        )?;
        let step = self.max_step;
        self.check(
            step.is_finite() && step > 0.0 && f64::from(step) < h,
            "max_step",
            format!(
                "must be > 0 and below arena_half_size {}, found {}",
                number(h),
                number(step)
            ),
        )?;
        let g = self.gamma;
        self.check(
            (0.0..1.0).contains(&g),
            "gamma",
            format!("must be in [0, 1), found {}", number(g)),
        )?;
        let t = self.time_limit;
        self.check(
            (1..=MAX_TIME_LIMIT).contains(&t),
            "time_limit",
            format!("must be in 1..={MAX_TIME_LIMIT}, found {t}"),
        )?;
        self.check(
            self.goal_hold > 0,
            "goal_hold",
            "must be > 0, found 0".into(),
        )?;
        let r = self.goal_radius;
        self.check(
            r.is_finite() && r > 0.0,
            "goal_radius",
            format!("must be > 0, found {}", number(r)),
        )?;
        self.validate_start()?;
        self.validate_metrics()?;
        self.validate_pass()?;
        self.walls
            .iter()
            .enumerate()
            .try_for_each(|(i, w)| self.validate_wall(i, w))
    }

    fn validate_start(&self) -> Result<(), Error> {
        let h = self.arena_half_size;
        match &self.start {
            StartRule::Boundary { inset } => self.check(
                inset.is_finite() && *inset >= 0.0 && *inset < h,
                "start.inset",
                format!(
                    "must be in [0, arena_half_size {}), found {}",
                    number(h),
                    number(*inset)
                ),
            ),
            StartRule::Points { points } => {
                self.check(
                    !points.is_empty(),
                    "start.points",
                    "must not be empty".into(),
                )?;
                points.iter().enumerate().try_for_each(|(i, p)| {
                    self.check(
                        p.iter().all(|c| c.is_finite() && c.abs() <= h),
                        &format!("start.points[{i}]"),
                        format!("{p:?} is outside the arena [-{h}, {h}]²"),
                    )
                })
            }
        }
    }

    fn validate_metrics(&self) -> Result<(), Error> {
        let m = &self.metrics;
        let t = self.time_limit;
        self.check(
            m.settle_window > 0 && m.settle_window <= t,
            "metrics.settle_window",
            format!("must be in 1..={t} (time_limit), found {}", m.settle_window),
        )?;
        self.check(
            m.stuck_window > 0,
            "metrics.stuck_window",
            "must be > 0, found 0".into(),
        )?;
        for (field, v) in [
            ("metrics.success_radius", m.success_radius),
            ("metrics.near_radius", m.near_radius),
        ] {
            self.check(
                v.is_finite() && v > 0.0,
                field,
                format!("must be > 0, found {}", number(v)),
            )?;
        }
        let c = m.stuck_min_command;
        self.check(
            c > 0.0 && c <= 1.0,
            "metrics.stuck_min_command",
            format!("must be in (0, 1], found {}", number(c)),
        )?;
        let p = m.stuck_max_progress;
        self.check(
            p.is_finite() && p >= 0.0,
            "metrics.stuck_max_progress",
            format!("must be >= 0, found {}", number(p)),
        )
    }

    fn validate_pass(&self) -> Result<(), Error> {
        for (field, v) in [
            ("pass.min_success_rate", self.pass.min_success_rate),
            ("pass.max_stuck_rate", self.pass.max_stuck_rate),
        ] {
            self.check(
                (0.0..=1.0).contains(&v),
                field,
                format!("must be in [0, 1], found {}", number(v)),
            )?;
        }
        Ok(())
    }

    fn validate_wall(&self, i: usize, w: &Wall) -> Result<(), Error> {
        let h = self.arena_half_size;
        let field = format!("walls[{i}]");
        let inside = w
            .from
            .iter()
            .chain(&w.to)
            .all(|c| c.is_finite() && c.abs() <= h);
        self.check(
            inside,
            &field,
            format!(
                "{:?} -> {:?} is outside the arena [-{h}, {h}]²",
                w.from, w.to
            ),
        )?;
        self.check(
            w.segment().length() >= 1e-6,
            &field,
            format!("{:?} -> {:?} has zero length", w.from, w.to),
        )
    }

    fn check(&self, ok: bool, field: &str, message: String) -> Result<(), Error> {
        if ok {
            return Ok(());
        }
        Err(Error::Invalid {
            scenario: self.name.clone(),
            field: field.to_string(),
            message,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_parse_and_validate() {
        for name in BUILTIN_NAMES {
            let s = Scenario::builtin(name).expect(name);
            assert_eq!(s.name, name);
            assert_eq!(s.time_limit, 200);
            assert_eq!(s.goal_hold, 10);
            assert_eq!(s.start, StartRule::Boundary { inset: 0.25 });
        }
        assert!(Scenario::builtin("nav-open")
            .expect("open")
            .walls
            .is_empty());
        assert!(Scenario::builtin("nope").is_none());
    }

    #[test]
    fn unknown_key_is_named_with_its_line() {
        let text = NAV_OPEN.replace("[pass]", "[pass]\nmax_stuk_rate = 0.1");
        let e = Scenario::from_toml_str(&text)
            .expect_err("must be refused")
            .to_string();
        assert!(
            e.contains("max_stuk_rate") && e.starts_with("<string>:"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
    }

    #[test]
    fn unknown_key_inside_a_wall_is_an_error() {
        let text =
            format!("{NAV_OPEN}\n[[walls]]\nfrom = [0.0, 0.0]\nto = [1.0, 0.0]\nthick = 1\n");
        let e = Scenario::from_toml_str(&text)
            .expect_err("must be refused")
            .to_string();
        assert!(e.contains("thick"), "{e}");
    }

    #[test]
    fn unknown_key_in_start_rule_is_an_error() {
        let text = NAV_OPEN.replace("inset = 0.25", "inset = 0.25\nonset = 1.0");
        let e = Scenario::from_toml_str(&text)
            .expect_err("must be refused")
            .to_string();
        assert!(e.contains("onset"), "{e}");
    }

    #[test]
    fn fixed_start_points_parse_and_are_checked() {
        let points = NAV_OPEN.replace(
            "rule = \"boundary\"\ninset = 0.25",
            "rule = \"points\"\npoints = [[1.0, 2.0], [-3.0, 0.5]]",
        );
        let s = Scenario::from_toml_str(&points).expect("points");
        assert_eq!(
            s.start,
            StartRule::Points {
                points: vec![[1.0, 2.0], [-3.0, 0.5]]
            }
        );
        let outside = points.replace("[-3.0, 0.5]", "[-3.0, 7.5]");
        let e = Scenario::from_toml_str(&outside)
            .expect_err("outside")
            .to_string();
        assert!(e.contains("start.points[1]"), "{e}");
    }

    #[test]
    fn wall_outside_the_arena_names_the_wall() {
        let text = format!("{NAV_OPEN}\n[[walls]]\nfrom = [0.0, 0.0]\nto = [7.0, 0.0]\n");
        let e = Scenario::from_toml_str(&text)
            .expect_err("must be refused")
            .to_string();
        assert!(
            e.contains("walls[0]") && e.contains("outside the arena"),
            "{e}"
        );
    }

    #[test]
    fn negative_and_zero_limits_are_refused() {
        for (from, to, field) in [
            ("time_limit = 200", "time_limit = -5", "time_limit"),
            ("time_limit = 200", "time_limit = 0", "time_limit"),
            ("time_limit = 200", "time_limit = 100001", "time_limit"),
            ("max_step = 0.25", "max_step = -0.25", "max_step"),
            ("goal_radius = 0.1", "goal_radius = 0.0", "goal_radius"),
            ("gamma = 0.99", "gamma = 1.0", "gamma"),
            ("stuck_window = 20", "stuck_window = 0", "stuck_window"),
        ] {
            let e = Scenario::from_toml_str(&NAV_OPEN.replace(from, to))
                .expect_err("must be refused")
                .to_string();
            assert!(e.contains(field), "{to}: {e}");
        }
    }

    /// Regression (fuzz finding, `fuzz/regressions/scenario/arena-beyond-f32.toml`): an
    /// `arena_half_size` above `f32::MAX` validated, and the plant then observed infinities.
    #[test]
    fn an_arena_beyond_the_maximum_is_refused() {
        let huge = NAV_OPEN.replace("arena_half_size = 6.0", "arena_half_size = 1e39");
        let e = Scenario::from_toml_str(&huge)
            .expect_err("must be refused")
            .to_string();
        assert!(
            e.contains("arena_half_size: must be in (0, 1000000]"),
            "{e}"
        );
    }

    /// Regression (fuzz finding, `fuzz/regressions/scenario/newline-in-name.toml`): a name with
    /// a line break split the validation error over two lines.
    #[test]
    fn a_name_with_a_line_break_keeps_the_error_on_one_line() {
        let text = NAV_OPEN
            .replace("name = \"nav-open\"", "name = \"a\\nb\"")
            .replace("time_limit = 200", "time_limit = 0");
        let e = Scenario::from_toml_str(&text)
            .expect_err("must be refused")
            .to_string();
        assert_eq!(e.lines().count(), 1, "{e}");
        assert!(e.starts_with("scenario a\\nb: time_limit"), "{e}");
    }

    /// Regression: `time_limit = 4294967295` validated, then the test grew
    /// memory for 28 s and aborted. The limit is now refused, in one line, before any work.
    #[test]
    fn a_time_limit_beyond_the_maximum_is_refused() {
        let at_max = NAV_OPEN.replace("time_limit = 200", "time_limit = 100000");
        assert_eq!(
            Scenario::from_toml_str(&at_max).expect("at max").time_limit,
            MAX_TIME_LIMIT
        );
        let huge = NAV_OPEN.replace("time_limit = 200", "time_limit = 4294967295");
        let e = Scenario::from_toml_str(&huge)
            .expect_err("must be refused")
            .to_string();
        assert_eq!(
            e,
            "scenario nav-open: time_limit: must be in 1..=100000, found 4294967295"
        );
    }

    /// Regression: a wall end written with extra values
    /// (`from = [-2.0, 1.0, 77.0]`) was accepted and the extra values silently ignored.
    #[test]
    fn a_wall_end_must_be_exactly_two_numbers() {
        for (wall, field, found) in [
            (
                r#"{ from = [-2.0, 1.0, 77.0], to = [2.0, 1.0] }"#,
                "walls[1].from",
                "[-2.0, 1.0, 77.0]",
            ),
            (
                r#"{ from = [-2.0, 1.0], to = [2.0, 1.0, "junk", true] }"#,
                "walls[1].to",
                r#"[2.0, 1.0, "junk", true]"#,
            ),
            (
                r#"{ from = [-2.0], to = [2.0, 1.0] }"#,
                "walls[1].from",
                "[-2.0]",
            ),
            (
                r#"{ from = [-2, "1"], to = [2, 1] }"#,
                "walls[1].from",
                r#"[-2.0, "1"]"#,
            ),
        ] {
            let text = format!("walls = [{{ from = [0, 0], to = [1, 0] }}, {wall}]\n{NAV_OPEN}");
            let e = Scenario::from_toml_str(&text).expect_err(wall).to_string();
            assert!(e.contains(field) && e.contains(found), "{wall}: {e}");
            assert!(e.contains("expected a point [x, y] of two numbers"), "{e}");
            assert!(!e.contains('\n'), "{e}");
        }
        // Integers are numbers too.
        let ok = format!("walls = [{{ from = [-2, 1], to = [2, 1] }}]\n{NAV_OPEN}");
        let s = Scenario::from_toml_str(&ok).expect("integer points");
        assert_eq!(s.walls[0].from, [-2.0, 1.0]);
    }
}
