//! The sizes the format allows, and the one check of a shape against them.

use crate::error::Error;
use crate::format::{ModelKind, Shape};

/// The largest observation size a blob may declare.
pub const MAX_OBSERVATIONS: usize = 1024;
/// The largest action size a blob may declare.
pub const MAX_ACTIONS: usize = 256;
/// The largest hidden width a blob may declare.
pub const MAX_WIDTH: usize = 1024;
/// The most hidden layers a blob may declare.
pub const MAX_DEPTH: usize = 64;
/// The most action-table rows a discrete policy may declare.
pub const MAX_CHOICES: usize = 1024;

impl Shape {
    /// Checks the shape against the format's limits and the kind's rules: at least one hidden
    /// layer of width at least 1, sizes within the documented maxima, and `choices` set for a
    /// discrete policy only.
    ///
    /// ```
    /// use policy_core::{Error, ModelKind, Shape};
    /// let s = Shape { observations: 2, actions: 2, width: 48, depth: 4, choices: 0 };
    /// assert_eq!(s.check(ModelKind::Actor), Ok(()));
    /// let huge = Shape { width: 4096, ..s };
    /// assert!(matches!(huge.check(ModelKind::Actor), Err(Error::ShapeBeyondLimits { .. })));
    /// assert!(s.check(ModelKind::Discrete).is_err()); // a discrete policy needs choices >= 1
    /// ```
    pub fn check(&self, kind: ModelKind) -> Result<(), Error> {
        let limits = [
            (
                "observations",
                self.observations as usize,
                1,
                MAX_OBSERVATIONS,
            ),
            ("actions", self.actions as usize, 1, MAX_ACTIONS),
            ("width", self.width as usize, 1, MAX_WIDTH),
            ("depth", self.depth as usize, 1, MAX_DEPTH),
        ];
        for (what, found, min, max) in limits {
            if found < min || found > max {
                return Err(Error::ShapeBeyondLimits {
                    what,
                    min,
                    max,
                    found,
                });
            }
        }
        let (min, max) = match kind {
            ModelKind::Discrete => (1, MAX_CHOICES),
            ModelKind::Actor | ModelKind::Critic => (0, 0),
        };
        let choices = self.choices as usize;
        if choices < min || choices > max {
            return Err(Error::ShapeBeyondLimits {
                what: "choices",
                min,
                max,
                found: choices,
            });
        }
        Ok(())
    }
}
