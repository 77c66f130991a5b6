//! Team against team (the paper's overall scores, figures 10–14): points between pairings drawn
//! from two teams of players, and each player's contribution to its team's score.
//!
//! Point k pairs a player drawn uniformly from team A with one drawn uniformly from team B
//! (stream `team-pairing` of the seed), team A serving the even points and team B the odd ones,
//! so each team serves half. A team's score is its share of the points won, lets left out; a
//! player's contribution is the points it won over the points it played.

use rand_core::Rng;
use serde::Serialize;

use super::agent::Player;
use super::game::Badminton;
use super::play::play_point;
use super::reference::PlayerKind;
use super::Config;
use crate::seed::stream;
use crate::Error;

/// The most points a team match plays.
pub const MAX_POINTS: u32 = 10_000_000;

/// One player's part in a team match.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Contribution {
    /// The player (its label or kind).
    pub name: String,
    /// Points it played.
    pub played: u32,
    /// Points it won.
    pub won: u32,
}

/// The outcome of a team match.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TeamScore {
    /// The scenario.
    pub scenario: String,
    /// The pairing seed.
    pub seed: u64,
    /// Points played, lets included.
    pub points: u32,
    /// Lets (rally cap).
    pub lets: u32,
    /// Points won by team A and by team B.
    pub won: [u32; 2],
    /// Each team's players, in the order given.
    pub players: [Vec<Contribution>; 2],
}

impl TeamScore {
    /// Team `t`'s share of the points won (lets left out); `None` if every point was a let.
    pub fn score(&self, t: usize) -> Option<f64> {
        let decided = self.won[0] + self.won[1];
        (decided > 0).then(|| f64::from(self.won[t]) / f64::from(decided))
    }

    /// The report for people: the score, then each player's contribution.
    pub fn summary(&self, names: [&str; 2]) -> String {
        let score = |t: usize| self.score(t).map_or("-".into(), |s| format!("{s:.3}"));
        let mut out = format!(
            "{} | team A {} vs team B {} | {} points, seed {}\n  score (share of points won)   A {}   B {}   (lets {})\n",
            self.scenario, names[0], names[1], self.points, self.seed, score(0), score(1), self.lets
        );
        for (t, team) in self.players.iter().enumerate() {
            for p in team {
                let share = if p.played == 0 {
                    "-".to_string()
                } else {
                    format!("{:.3}", f64::from(p.won) / f64::from(p.played))
                };
                out += &format!(
                    "  {} {:<28} won {share} of {} points\n",
                    ["A", "B"][t],
                    p.name,
                    p.played
                );
            }
        }
        out
    }
}

/// Plays `points` points between pairings of team A (`teams[0]`) and team B, seed `seed`.
///
/// ```
/// use firmware_sim::badminton::reference::PlayerKind;
/// use firmware_sim::badminton::teams::team_match;
/// use firmware_sim::badminton::Config;
/// let teams = [vec![PlayerKind::Scripted], vec![PlayerKind::Random, PlayerKind::Random]];
/// let score = team_match(&Config::builtin(), &teams, 40, 0).unwrap();
/// assert_eq!(score.points, 40);
/// assert!(score.score(0).unwrap() > 0.8, "{score:?}");
/// assert_eq!(score.players[1].iter().map(|p| p.played).sum::<u32>(), 40);
/// ```
pub fn team_match(
    config: &Config,
    teams: &[Vec<PlayerKind>; 2],
    points: u32,
    seed: u64,
) -> Result<TeamScore, Error> {
    if teams.iter().any(Vec::is_empty) || !(1..=MAX_POINTS).contains(&points) {
        return Err(Error::Config {
            field: "teams",
            message: format!(
                "expected a player in each team and 1..={MAX_POINTS} points, found teams of {} and {}, {points} points",
                teams[0].len(),
                teams[1].len()
            ),
        });
    }
    let mut game = Badminton::new(config)?;
    // Each player is built once, with its own stream, and keeps it across its points.
    let mut built: [Vec<Option<Box<dyn Player + '_>>>; 2] = [0, 1].map(|t| {
        (teams[t].iter().enumerate())
            .map(|(i, kind)| Some(kind.build(config, player_seed(seed, t, i), t)))
            .collect()
    });
    let mut score = TeamScore {
        scenario: config.name.clone(),
        seed,
        players: [0, 1].map(|t| {
            (teams[t].iter())
                .map(|k| Contribution {
                    name: k.to_string(),
                    ..Contribution::default()
                })
                .collect()
        }),
        ..TeamScore::default()
    };
    let mut rng = stream(seed, "team-pairing", 0);
    for k in 0..points {
        let pick = [0, 1].map(|t| (rng.next_u64() % teams[t].len() as u64) as usize);
        let (Some(a), Some(b)) = (built[0][pick[0]].take(), built[1][pick[1]].take()) else {
            unreachable!("every player is put back after its point");
        };
        let mut pair = [a, b];
        game.new_match();
        game.set_server((k % 2) as usize);
        let end = play_point(&mut game, &mut pair);
        let [a, b] = pair;
        (built[0][pick[0]], built[1][pick[1]]) = (Some(a), Some(b));
        score.points += 1;
        for (team, &i) in score.players.iter_mut().zip(&pick) {
            team[i].played += 1;
        }
        match end.winner {
            Some(t) => {
                score.won[t] += 1;
                score.players[t][pick[t]].won += 1;
            }
            None => score.lets += 1,
        }
    }
    Ok(score)
}

/// A team named on the command line: `scripted` or `random` (a team of that one player), a
/// player folder (a team of one), or a folder of player folders (a trained team's `players/`,
/// or the team folder holding it), its players in name order.
pub fn team_of(arg: &str) -> Result<Vec<PlayerKind>, Error> {
    let path = std::path::Path::new(arg);
    let players = path.join("players");
    let dir = if players.is_dir() {
        players
    } else {
        path.to_path_buf()
    };
    if !dir.is_dir() || dir.join(super::blob_player::MANIFEST).is_file() {
        return Ok(vec![arg.parse()?]);
    }
    let io = |e: std::io::Error| Error::Player {
        player: arg.to_string(),
        message: format!("cannot list the team's players: {e}"),
    };
    let mut folders = Vec::new();
    for entry in std::fs::read_dir(&dir).map_err(io)? {
        let folder = entry.map_err(io)?.path();
        // A hidden folder is not a player (an export writes its players into one first).
        let hidden = folder
            .file_name()
            .is_some_and(|n| n.to_string_lossy().starts_with('.'));
        if folder.join(super::blob_player::MANIFEST).is_file() {
            folders.push(folder);
        } else if folder.is_dir() && !hidden {
            // Playing the others would be a smaller team than the one trained, without a word.
            return Err(Error::Player {
                player: folder.display().to_string(),
                message: format!(
                    "a folder among the team's players without {}: an incomplete player (an export stopped mid-way?); export the team again, or remove the folder",
                    super::blob_player::MANIFEST
                ),
            });
        }
    }
    folders.sort();
    if folders.is_empty() {
        return Err(Error::Player {
            player: arg.to_string(),
            message: format!(
                "no player folder in {} (a team is a folder of folders holding {})",
                dir.display(),
                super::blob_player::MANIFEST
            ),
        });
    }
    (folders.iter())
        .map(|f| f.display().to_string().parse())
        .collect()
}

/// The seed of player `i` of team `t`'s own stream in a team match seeded with `seed`.
fn player_seed(seed: u64, t: usize, i: usize) -> u64 {
    stream(seed, "team-player", (t as u64) << 32 | i as u64).next_u64()
}
