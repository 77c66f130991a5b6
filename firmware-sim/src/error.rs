//! The one error type of firmware-sim.

use std::fmt;

/// Everything that can go wrong when loading a scenario, building a plant or running the loop.
///
/// Every variant renders as one line that says where the problem is and what was expected, so
/// the CLI can print it as is.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// A scenario file could not be read.
    Io {
        /// The file.
        path: String,
        /// The operating system's message.
        message: String,
    },
    /// A scenario is not valid TOML or has an unknown, missing or mistyped key.
    Parse {
        /// Where: the file (or `<string>`), line and column.
        location: String,
        /// What the parser expected and found.
        message: String,
    },
    /// A scenario parsed but one of its values breaks a rule.
    Invalid {
        /// The scenario.
        scenario: String,
        /// The offending field, e.g. `walls[3]` or `time_limit`.
        field: String,
        /// The rule and the value found.
        message: String,
    },
    /// No built-in scenario has this name and no file with this path exists.
    UnknownScenario {
        /// The name given.
        name: String,
        /// The built-in names it could have been.
        builtin: &'static [&'static str],
    },
    /// A blob was rejected by policy-core.
    Blob(policy_core::Error),
    /// A controller or blob does not fit the plant's observation or action size.
    SizeMismatch {
        /// What does not fit.
        what: &'static str,
        /// The size the plant has.
        expected: usize,
        /// The size found.
        found: usize,
    },
    /// Neither flash slot holds a policy the firmware can run (the safe state runs).
    NoSlot {
        /// What became of slot A.
        a: policy_core::slot::Status,
        /// What became of slot B.
        b: policy_core::slot::Status,
    },
    /// Hardware in the loop: the chip, its link or the emulator failed (one line: what and
    /// what to do).
    Hil(String),
    /// A badminton player argument names no player, or a player folder
    /// ([`crate::badminton::blob_player`]) cannot be played: no `player.toml`, a manifest that
    /// does not parse or breaks a rule, a path outside the folder, a blob missing, unreadable or
    /// of the wrong shape for its agent.
    Player {
        /// The argument or folder, as given.
        player: String,
        /// What is wrong.
        message: String,
    },
    /// A plant in another process (the plant link) could not start, stopped answering, or
    /// answered outside the protocol or its own boxes.
    Plant {
        /// The plant's command, as given.
        plant: String,
        /// Which request failed and what was expected.
        message: String,
    },
    /// An evaluation or fault setting is out of range.
    Config {
        /// The setting.
        field: &'static str,
        /// The rule and the value found.
        message: String,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Io { path, message } => write!(f, "cannot read {path}: {message}"),
            Error::Parse { location, message } => write!(f, "{location}: {message}"),
            Error::Invalid {
                scenario,
                field,
                message,
            } => {
                // Escaped: a name with a line break must not split the one-line error (a fuzz
                // finding).
                write!(
                    f,
                    "scenario {}: {field}: {message}",
                    scenario.escape_debug()
                )
            }
            Error::UnknownScenario { name, builtin } => write!(
                f,
                "unknown scenario {name:?}: expected a built-in name ({}) or a TOML file path",
                builtin.join(", ")
            ),
            Error::Blob(e) => write!(f, "blob rejected: {e}"),
            Error::SizeMismatch {
                what,
                expected,
                found,
            } => {
                write!(f, "{what}: the plant needs {expected}, found {found}")
            }
            Error::NoSlot { a, b } => write!(
                f,
                "no slot holds a policy this plant's firmware can run: slot A {a}; slot B {b}"
            ),
            Error::Player { player, message } => {
                write!(f, "player {player:?}: {message}")
            }
            Error::Plant { plant, message } => write!(f, "plant {plant:?}: {message}"),
            Error::Config { field, message } => write!(f, "{field}: {message}"),
            Error::Hil(message) => write!(f, "{message}"),
        }
    }
}

impl std::error::Error for Error {}

/// So that a streaming evaluation ([`crate::nav::test_protocol::evaluate_streaming`]) can write its
/// records to files and return either kind of error as an `io::Error`.
impl From<Error> for std::io::Error {
    fn from(e: Error) -> Self {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, e)
    }
}

impl From<policy_core::Error> for Error {
    fn from(e: policy_core::Error) -> Self {
        Error::Blob(e)
    }
}

/// A one-line parse error with the line and column of the offending key.
pub(crate) fn parse_error(e: &toml::de::Error, text: &str, origin: &str) -> Error {
    let mut message = e.message().trim().replace('\n', " ");
    let location = match e.span() {
        Some(span) => {
            let start = span.start.min(text.len());
            let before = &text[..start];
            let line = before.matches('\n').count() + 1;
            let line_start = before.rfind('\n').map_or(0, |i| i + 1);
            let column = start - line_start + 1;
            // The serde message may not name the key (`invalid value: integer -5`), the line does.
            let source = text[line_start..].lines().next().unwrap_or("").trim();
            if !source.is_empty() {
                message = format!("{message} (in `{source}`)");
            }
            format!("{origin}:{line}:{column}")
        }
        None => origin.to_string(),
    };
    // A file's NUL bytes and other control characters are escaped, not echoed into the line.
    Error::Parse {
        location,
        message: printable(&message),
    }
}

/// A number for a message: as written for ordinary magnitudes, in exponent form past them, so
/// 1e308 or `f32::MAX` does not print as a 309- or 39-digit decimal.
///
/// ```
/// use firmware_sim::error::number;
/// assert_eq!(number(1e300), "1e300");
/// assert_eq!(number(2.5), "2.5");
/// ```
pub fn number<T>(v: T) -> String
where
    T: Into<f64> + fmt::Display + fmt::LowerExp + Copy,
{
    let x: f64 = v.into();
    if x != 0.0 && x.is_finite() && !(1e-4..1e9).contains(&x.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// `text` with control characters escaped (`\u{0}`), so bytes from a file can be quoted in a
/// one-line error without breaking it or the terminal.
pub(crate) fn printable(text: &str) -> String {
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    /// Regression: `f32::MAX` printed as a 39-digit decimal in scenario errors.
    #[test]
    fn huge_numbers_print_in_exponent_form() {
        assert_eq!(super::number(f32::MAX), "3.4028235e38");
        assert_eq!(super::number(1e308), "1e308");
        assert_eq!(super::number(0.25f32), "0.25");
        let text = include_str!("../scenarios/nav-open.toml")
            .replace("arena_half_size = ", "arena_half_size = 1e39 #");
        let e = crate::nav::scenario::Scenario::from_toml_str(&text)
            .expect_err("too large")
            .to_string();
        assert!(e.len() < 150, "{e}");
    }

    /// Regression: NUL bytes of a scenario file were echoed into the error line.
    #[test]
    fn nul_bytes_of_a_file_are_escaped_in_parse_errors() {
        let text = "time_limit = \"a\0b\u{1b}[31m\"\n";
        let e = crate::nav::scenario::Scenario::from_toml_str(text)
            .expect_err("a string for a number")
            .to_string();
        assert!(!e.chars().any(char::is_control), "{e:?}");
        assert!(e.contains("\\u{0}"), "{e}");
    }
}
