//! The hidden layers of a network, written `DEPTHxWIDTH` as in the paper.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::Error;

/// A hidden-layer shape, written `DEPTHxWIDTH` as in the paper ("4x48": four hidden layers of
/// 48 units).
///
/// ```
/// use host_trainer::nn::hidden::Hidden;
/// let h: Hidden = "4x48".parse().expect("hand-made test value");
/// assert_eq!((h.depth, h.width), (4, 48));
/// assert_eq!(h.to_string(), "4x48");
/// assert!("4by48".parse::<Hidden>().is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Hidden {
    /// Number of hidden layers (>= 1).
    pub depth: usize,
    /// Units per hidden layer (>= 1).
    pub width: usize,
}

impl FromStr for Hidden {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self, Error> {
        let bad = || Error::InvalidConfig {
            what: "hidden".into(),
            expected: "DEPTHxWIDTH with positive integers, e.g. 4x48".into(),
            found: s.into(),
        };
        let (d, w) = s.split_once('x').ok_or_else(bad)?;
        let depth: usize = d.trim().parse().map_err(|_| bad())?;
        let width: usize = w.trim().parse().map_err(|_| bad())?;
        if depth == 0 || width == 0 {
            return Err(bad());
        }
        Ok(Hidden { depth, width })
    }
}

impl TryFrom<String> for Hidden {
    type Error = Error;
    fn try_from(s: String) -> Result<Self, Error> {
        s.parse()
    }
}

impl From<Hidden> for String {
    fn from(h: Hidden) -> String {
        h.to_string()
    }
}

impl fmt::Display for Hidden {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.depth, self.width)
    }
}
