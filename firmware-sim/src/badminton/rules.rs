//! Points, games and who serves (docs/design.md §3, "Points and games").
//!
//! Player 0 serves first in the first game, the winner of a game first in the next; the winner
//! of a point serves the next; a let changes nothing. A game ends when a player has at least
//! `game_points` (11: "more than 10") with a lead of `lead` (2), or reaches `point_cap` (20).
//!
//! ```
//! use firmware_sim::badminton::rules::Score;
//! use firmware_sim::badminton::Config;
//! let rules = Config::builtin().rules;
//! let mut score = Score::new();
//! for _ in 0..11 {
//!     score.point(1, &rules);
//! }
//! assert_eq!((score.games, score.points, score.server), ([0, 1], [0, 0], 1));
//! ```

use serde::{Deserialize, Serialize};

use super::config::RulesConfig;

/// Why a point ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Cause {
    /// The hitter's ball landed out.
    Out,
    /// The hitter's ball hit the net or landed on its own side.
    Net,
    /// The receiver missed a ball that landed in.
    MissedCatch,
    /// The rally reached the cap: no point.
    Let,
}

/// How a point ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PointEnd {
    /// Who won it (`None` for a let).
    pub winner: Option<usize>,
    /// Why.
    pub cause: Cause,
    /// Hits in the rally, the serve included.
    pub hits: u32,
}

/// The score of a match.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Score {
    /// Points in the current game, per player.
    pub points: [u32; 2],
    /// Games won, per player.
    pub games: [u32; 2],
    /// Who serves the next point.
    pub server: usize,
}

impl Score {
    /// 0–0, player 0 to serve.
    pub fn new() -> Score {
        Score::default()
    }

    /// Records a point won by `winner`; returns `Some(winner)` if it ended the game (the
    /// points then start again from 0–0).
    pub fn point(&mut self, winner: usize, rules: &RulesConfig) -> Option<usize> {
        self.points[winner] += 1;
        self.server = winner;
        let won = game_winner(self.points, rules)?;
        self.games[won] += 1;
        self.points = [0, 0];
        self.server = won;
        Some(won)
    }

    /// Records the end of a point (a let leaves everything as it was); returns the game's
    /// winner if the point ended a game.
    pub fn record(&mut self, end: &PointEnd, rules: &RulesConfig) -> Option<usize> {
        end.winner.and_then(|w| self.point(w, rules))
    }
}

/// The winner of a game at this score, if it is over.
///
/// ```
/// use firmware_sim::badminton::rules::game_winner;
/// use firmware_sim::badminton::Config;
/// let rules = Config::builtin().rules;
/// assert_eq!(game_winner([11, 9], &rules), Some(0));
/// assert_eq!(game_winner([11, 10], &rules), None);
/// assert_eq!(game_winner([10, 12], &rules), Some(1));
/// assert_eq!(game_winner([20, 19], &rules), Some(0));
/// ```
pub fn game_winner(points: [u32; 2], rules: &RulesConfig) -> Option<usize> {
    (0..2).find(|&p| {
        let (own, other) = (points[p], points[1 - p]);
        own >= rules.point_cap || (own >= rules.game_points && own >= other + rules.lead)
    })
}
