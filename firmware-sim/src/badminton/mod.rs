//! Experiment 2: badminton singles (docs/design.md §3), a plant of two players with three
//! agents each (catch, serve, reset), and its reference players and measures.
//!
//! - [`config`]: every constant as data (`scenarios/badminton.toml`), validated;
//! - [`court`]: the court, the halves and the players' frames; [`shuttle`]: f64 physics with
//!   quadratic drag and the events of a flight; [`player`]: bodies with their speed limit and
//!   margins, and how actions map onto targets and hits; [`rules`]: points, games, who serves;
//! - [`game`]: the plant ([`Badminton`], a [`crate::env::Plant`]);
//! - [`mod@reference`]: the `random` and `scripted` players ([`clear`]: the scripted clear's
//!   speed); [`agent`]: the [`agent::Player`] trait every seat plays through;
//!   [`blob_player`]: players made of three blobs, loaded from a player folder; [`play`]:
//!   matches and the paper's measures; [`figure`]: one rally drawn from above and from the
//!   side; [`heatmap`]: a critic's Q over the court (catch targets, serve landing points);
//!   [`teams`]: team against team, and each player's contribution.

pub mod agent;
pub mod blob_player;
pub mod clear;
pub mod config;
pub mod court;
pub mod figure;
pub mod game;
pub mod heatmap;
pub mod play;
pub mod player;
pub mod reference;
pub mod rules;
pub mod shuttle;
pub mod teams;

pub use config::Config;
pub use game::{Badminton, Role};
