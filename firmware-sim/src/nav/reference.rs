//! Navigation's reference controllers by name (`straight`, `oracle`), as the CLI's
//! `--controller` picks them.

use super::oracle::Oracle;
use super::scenario::Scenario;
use super::straight::Straight;
use crate::controller::Controller;
use crate::Error;

/// A reference controller by name: `straight` or `oracle`.
///
/// ```
/// use firmware_sim::nav::reference::reference;
/// use firmware_sim::nav::scenario::Scenario;
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let mut c = reference("straight", &s).unwrap();
/// let mut a = [0.0; 2];
/// c.act(&[5.75, 0.0], &mut a);
/// assert_eq!(a, [-0.25, 0.0]);
/// assert!(reference("wander", &s).is_err());
/// ```
pub fn reference(name: &str, scenario: &Scenario) -> Result<Box<dyn Controller>, Error> {
    match name {
        "straight" => Ok(Box::new(Straight {
            max_step: scenario.max_step,
        })),
        "oracle" => Ok(Box::new(Oracle::new(scenario))),
        _ => Err(Error::Config {
            field: "controller",
            message: format!("expected straight or oracle, found {name:?}"),
        }),
    }
}
