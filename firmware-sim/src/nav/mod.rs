//! Experiment 1: blind navigation among walls (docs/design.md §2), the plant, its layouts, the
//! reference controllers that check the harness, and the test protocol that scores a policy's
//! behaviour at the margins.
//!
//! - [`scenario`]: a layout as TOML data (`scenarios/nav-walls.toml`, `nav-open.toml`),
//!   validated; [`geometry`]: exact sliding motion among zero-thickness walls;
//!   [`mod@reward`]: the reward forms (LR, GR, LR+GR);
//! - [`plant`]: the plant ([`NavEnv`], an [`crate::env::Env`]);
//! - [`straight`] and [`oracle`]: the reference controllers (the naive one a wall catches, and
//!   the planner that follows the gaps); [`mod@reference`]: them by name;
//! - [`faults`]: the faults a test injects (sensor dropouts, a stuck actuator, a wall that
//!   appears or moves);
//! - [`test_protocol`]: the firmware loop run against the plant for a set of test starts, scored
//!   by the margin [`metrics`]; its report as JSON ([`json_report`]) and as a trajectory plot
//!   ([`svg`]).

pub mod faults;
pub mod generator;
pub mod geometry;
pub mod json_report;
pub mod metrics;
pub mod oracle;
pub mod plant;
pub mod reference;
pub mod reward;
pub mod scenario;
pub mod straight;
pub mod svg;
pub mod test_protocol;

pub use plant::NavEnv;
pub use reward::Reward;
pub use scenario::Scenario;
