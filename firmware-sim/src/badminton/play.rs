//! Matches between two players and the paper's test measures (docs/design.md §3, "Measures"):
//! the catch test, the serve test, and catch success with the reset agent enabled or disabled.
//! They take any [`Player`], so the trainer can call them later with trained players.
//!
//! ```
//! use firmware_sim::badminton::play::{play_match, Length};
//! use firmware_sim::badminton::reference::PlayerKind;
//! use firmware_sim::badminton::Config;
//! let config = Config::builtin();
//! let kinds = [PlayerKind::Scripted, PlayerKind::Random];
//! let report = play_match(&config, &kinds, Length::Games(1), 3, false, |_| {}).unwrap();
//! assert_eq!(report.games[0] + report.games[1], 1);
//! assert!(report.players[0].points_won > report.players[1].points_won);
//! ```

use serde::{Deserialize, Serialize};

use super::config::{Config, MatchPass};
use super::game::{Badminton, Role};
use super::reference::{Player, PlayerKind};
use super::rules::{Cause, PointEnd};
use super::shuttle::Fate;
use crate::env::Plant;
use crate::pass::PassOutcome;
use crate::Error;

/// How long a match lasts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Length {
    /// This many games.
    Games(u32),
    /// This many points (lets included).
    Points(u32),
}

/// A success count over a number of trials.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rate {
    /// What counted.
    pub hits: u32,
    /// Out of this many.
    pub of: u32,
}

impl Rate {
    /// `hits / of`, or `None` with no trials.
    pub fn value(&self) -> Option<f64> {
        (self.of > 0).then(|| f64::from(self.hits) / f64::from(self.of))
    }

    fn show(&self) -> String {
        match self.value() {
            Some(v) => format!("{v:.3} ({}/{})", self.hits, self.of),
            None => "- (0/0)".into(),
        }
    }
}

/// One player's tallies over a match.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PlayerStats {
    /// The player's name.
    pub name: String,
    /// Points won.
    pub points_won: u32,
    /// ... because the opponent's ball landed out.
    pub won_by_out: u32,
    /// ... because the opponent's ball hit the net (or landed on its own side).
    pub won_by_net: u32,
    /// ... because the opponent missed a ball that landed in.
    pub won_by_missed_catch: u32,
    /// Incoming balls that would land in (out and net balls ignored), and how many it caught.
    pub catches: Rate,
    /// Its hits, and how many went out or into the net.
    pub serve_errors: Rate,
    /// The agents (a player folder's) that played the safe state because their blob did not
    /// boot: `"serve: blob rejected: ..."`. Absent from the JSON when empty.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub boot_errors: Vec<String>,
}

/// The result of a match.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MatchReport {
    /// Scenario name.
    pub scenario: String,
    /// Seed of the players' random streams.
    pub seed: u64,
    /// How long the match was asked to last.
    pub length: Length,
    /// Per player.
    pub players: [PlayerStats; 2],
    /// Games won per player.
    pub games: [u32; 2],
    /// Points in the unfinished last game (0–0 when the match ended with a game).
    pub points_in_game: [u32; 2],
    /// Points played, lets included.
    pub points: u32,
    /// Points cut at the rally cap.
    pub lets: u32,
    /// Hits over all points.
    pub hits: u64,
    /// Physics steps run.
    pub physics_steps: u64,
    /// The scenario's pass criteria.
    pub pass: PassOutcome,
}

/// Plays a match between two players built from their kinds (seats 0 and 1) and judges it by
/// the scenario's pass criteria; `on_point` sees the plant after every point (with
/// `record_rallies`, its [`Badminton::rally`] holds the point's rally, to keep one for drawing).
pub fn play_match(
    config: &Config,
    kinds: &[PlayerKind; 2],
    length: Length,
    seed: u64,
    record_rallies: bool,
    on_point: impl FnMut(&Badminton),
) -> Result<MatchReport, Error> {
    let mut game = Badminton::new(config)?;
    game.record_rallies(record_rallies);
    let mut players = [0, 1].map(|seat| kinds[seat].build(config, seed, seat));
    let mut report = play(&mut game, &mut players, length, on_point);
    report.seed = seed;
    report.pass = judge(
        &report,
        &config.pass,
        kinds.each_ref().map(PlayerKind::is_judged),
    );
    for (seat, kind) in kinds.iter().enumerate() {
        for (role, e) in kind.boot_errors() {
            report.mark_boot_failure(seat, role, &e);
        }
    }
    Ok(report)
}

/// Plays points of the plant's match (from 0–0) until `length` is reached. A match of `n` games
/// also stops, unfinished, after `4 · point_cap · n` points: lets do not count, and two players
/// who never miss would let forever (the let rate then fails the pass criteria).
pub fn play<'a>(
    game: &mut Badminton,
    players: &mut [Box<dyn Player + 'a>; 2],
    length: Length,
    mut on_point: impl FnMut(&Badminton),
) -> MatchReport {
    game.new_match();
    let steps_before = game.physics_steps();
    let mut report = MatchReport {
        scenario: game.config().name.clone(),
        seed: 0,
        length,
        players: [0, 1].map(|p| PlayerStats {
            name: players[p].name(),
            ..PlayerStats::default()
        }),
        games: [0, 0],
        points_in_game: [0, 0],
        points: 0,
        lets: 0,
        hits: 0,
        physics_steps: 0,
        pass: PassOutcome {
            passed: true,
            failures: Vec::new(),
        },
    };
    let most_points = points_limit(length, game.config().rules.point_cap);
    while !over(&report, length) && report.points < most_points {
        let end = play_point(game, players);
        tally(&mut report, game, end);
        on_point(game);
    }
    report.physics_steps = game.physics_steps() - steps_before;
    report
}

/// The most points a match plays. A game without lets has fewer than `2 · point_cap` points, but
/// lets do not count: two players who never miss (scripted without noise) would let forever. So
/// a match of `n` games stops after `4 · point_cap · n` points, unfinished; its let rate then
/// fails the pass criteria.
fn points_limit(length: Length, point_cap: u32) -> u32 {
    match length {
        Length::Games(n) => n.saturating_mul(4).saturating_mul(point_cap),
        Length::Points(n) => n,
    }
}

fn over(report: &MatchReport, length: Length) -> bool {
    match length {
        Length::Games(n) => report.games[0] + report.games[1] >= n,
        Length::Points(n) => report.points >= n,
    }
}

/// Plays one point to its end.
pub fn play_point<'a>(game: &mut Badminton, players: &mut [Box<dyn Player + 'a>; 2]) -> PointEnd {
    let mut turn = game.reset(0);
    let mut action = [0.0f32; 3];
    while let Some(decision) = turn.decide {
        let (player, role) = Badminton::role_of(decision.agent);
        let action = &mut action[..role.actions()];
        players[player].act(role, &decision.observation, action);
        turn = game.act(action);
    }
    match game.point_end() {
        Some(end) => end,
        // `act` runs the physics until a decision or the end, so no decision means an end.
        None => unreachable!("a point ended without an end"),
    }
}

fn tally(report: &mut MatchReport, game: &Badminton, end: PointEnd) {
    report.points += 1;
    report.hits += u64::from(end.hits);
    let score = game.score();
    report.games = score.games;
    report.points_in_game = score.points;
    tally_hits(&mut report.players, game);
    let Some(winner) = end.winner else {
        report.lets += 1;
        return;
    };
    let w = &mut report.players[winner];
    w.points_won += 1;
    match end.cause {
        Cause::Out => w.won_by_out += 1,
        Cause::Net => w.won_by_net += 1,
        Cause::MissedCatch => w.won_by_missed_catch += 1,
        Cause::Let => {}
    }
}

/// Counts the catch and serve records of a point's hits.
fn tally_hits(players: &mut [PlayerStats; 2], game: &Badminton) {
    for hit in game.hits() {
        let serve = &mut players[hit.hitter].serve_errors;
        serve.of += 1;
        serve.hits += u32::from(hit.fate.is_fault());
        if let Fate::In(_) = hit.fate {
            let catches = &mut players[1 - hit.hitter].catches;
            catches.of += 1;
            catches.hits += u32::from(hit.caught);
        }
    }
}

/// The scenario's pass criteria, for the players `judged` (everyone but `random`).
pub fn judge(report: &MatchReport, pass: &MatchPass, judged: [bool; 2]) -> PassOutcome {
    let mut failures = Vec::new();
    let decided = report.points - report.lets;
    for p in (0..2).filter(|&p| judged[p]) {
        let s = &report.players[p];
        let who = format!("p{p} {}", s.name);
        if let Some(rate) = s
            .serve_errors
            .value()
            .filter(|&r| r > pass.max_serve_error_rate)
        {
            failures.push(format!(
                "{who}: serve error rate {rate:.3} is above the maximum {:.3}",
                pass.max_serve_error_rate
            ));
        }
        if let Some(rate) = s.catches.value().filter(|&r| r < pass.min_catch_rate) {
            failures.push(format!(
                "{who}: catch success rate {rate:.3} is below the minimum {:.3}",
                pass.min_catch_rate
            ));
        }
        let won = f64::from(s.points_won) / f64::from(decided.max(1));
        if !judged[1 - p] && decided > 0 && won < pass.min_points_won_vs_random {
            failures.push(format!(
                "{who}: won {won:.3} of the points against random, below the minimum {:.3}",
                pass.min_points_won_vs_random
            ));
        }
    }
    let lets = f64::from(report.lets) / f64::from(report.points.max(1));
    if lets > pass.max_let_rate {
        failures.push(format!(
            "let rate {lets:.3} is above the maximum {:.3}",
            pass.max_let_rate
        ));
    }
    PassOutcome {
        passed: failures.is_empty(),
        failures,
    }
}

impl MatchReport {
    /// Records that player `seat`'s `role` agent played the safe state because its blob did not
    /// boot (`why`): the match fails, that reason first, as a navigation run's boot failure does
    /// ([`crate::nav::test_protocol::Report::mark_boot_failure`]).
    pub fn mark_boot_failure(&mut self, seat: usize, role: Role, why: &str) {
        let player = &mut self.players[seat.min(1)];
        player.boot_errors.push(format!("{}: {why}", role.name()));
        let failure = format!(
            "p{seat} {}: the {} blob did not boot: {why} (played the safe state: zero action)",
            player.name,
            role.name()
        );
        let first_after_boot = self
            .pass
            .failures
            .iter()
            .take_while(|f| f.contains("did not boot"))
            .count();
        self.pass.failures.insert(first_after_boot, failure);
        self.pass.passed = false;
    }

    /// The table `firmware-sim match` prints.
    pub fn summary(&self) -> String {
        let [a, b] = &self.players;
        let plural = |n: u32, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
        let length = match self.length {
            Length::Games(n) => plural(n, "game"),
            Length::Points(n) => plural(n, "point"),
        };
        let mut out = format!(
            "{} | p0 {} vs p1 {} | {length}, seed {}\n",
            self.scenario, a.name, b.name, self.seed
        );
        let rows: [(&str, String, String); 7] = [
            (
                "games won",
                self.games[0].to_string(),
                self.games[1].to_string(),
            ),
            (
                "points won",
                a.points_won.to_string(),
                b.points_won.to_string(),
            ),
            (
                "  by opponent's out",
                a.won_by_out.to_string(),
                b.won_by_out.to_string(),
            ),
            (
                "  by opponent's net",
                a.won_by_net.to_string(),
                b.won_by_net.to_string(),
            ),
            (
                "  by opponent's missed catch",
                a.won_by_missed_catch.to_string(),
                b.won_by_missed_catch.to_string(),
            ),
            (
                "catch success (in-balls)",
                a.catches.show(),
                b.catches.show(),
            ),
            (
                "serve error (out + net)",
                a.serve_errors.show(),
                b.serve_errors.show(),
            ),
        ];
        out.push_str(&format!("  {:<30} {:<22} {}\n", "", "p0", "p1"));
        for (k, x, y) in &rows {
            out.push_str(&format!("  {k:<30} {x:<22} {y}\n"));
        }
        for (seat, p) in self.players.iter().enumerate() {
            for e in &p.boot_errors {
                let what = "safe state (blob did not boot)";
                out.push_str(&format!("  {what:<30} p{seat} {e}\n"));
            }
        }
        let verdict = if self.pass.passed {
            "PASS".to_string()
        } else {
            format!("FAIL ({})", self.pass.failures.join("; "))
        };
        for (k, v) in [
            ("points played", self.points.to_string()),
            ("lets (rally cap)", self.lets.to_string()),
            ("hits", self.hits.to_string()),
            ("physics steps", self.physics_steps.to_string()),
            ("pass criteria", verdict),
        ] {
            out.push_str(&format!("  {k:<30} {v}\n"));
        }
        out
    }
}

/// The catch test (table 5): `balls` serves by `server` to `catcher`, each the first ball of a
/// point from the start positions; balls that land out or in the net are ignored. Returns the
/// catcher's catches over the in-balls.
///
/// ```
/// use firmware_sim::badminton::play::catch_test;
/// use firmware_sim::badminton::reference::PlayerKind;
/// use firmware_sim::badminton::Config;
/// let c = Config::builtin();
/// let mut catcher = PlayerKind::Scripted.build(&c, 1, 0);
/// let mut server = PlayerKind::Scripted.build(&c, 1, 1);
/// let rate = catch_test(&c, catcher.as_mut(), server.as_mut(), 20).unwrap();
/// assert!(rate.of >= 15 && rate.value().unwrap() > 0.8, "{rate:?}");
/// ```
pub fn catch_test(
    config: &Config,
    catcher: &mut dyn Player,
    server: &mut dyn Player,
    balls: u32,
) -> Result<Rate, Error> {
    let mut game = Badminton::new(config)?;
    let mut rate = Rate::default();
    let mut action = [0.0f32; 3];
    for _ in 0..balls {
        game.set_server(1);
        let mut turn = game.reset(0);
        // Serve, the server's reset, the catcher's catch; then the ball is caught or dead.
        while let Some(decision) = turn.decide {
            let (player, role) = Badminton::role_of(decision.agent);
            if player == 0 && role == Role::Serve {
                break;
            }
            let action = &mut action[..role.actions()];
            let who: &mut dyn Player = if player == 0 { catcher } else { server };
            who.act(role, &decision.observation, action);
            turn = game.act(action);
        }
        if let Some(first) = game.hits().first().filter(|h| !h.fate.is_fault()) {
            rate.of += 1;
            rate.hits += u32::from(first.caught);
        }
    }
    Ok(rate)
}

/// The serve test (table 6): `serves` first serves of a point by `server`; returns how many went
/// out or into the net. Every serve counts (each is played to its dead ball: the plant knows
/// where it lands whether or not it is caught).
///
/// ```
/// use firmware_sim::badminton::play::serve_test;
/// use firmware_sim::badminton::reference::PlayerKind;
/// use firmware_sim::badminton::Config;
/// let c = Config::builtin();
/// let errors = serve_test(&c, PlayerKind::Random.build(&c, 1, 0).as_mut(), 50).unwrap();
/// assert_eq!(errors.of, 50);
/// assert!(errors.value().unwrap() > 0.5); // random serves are mostly out or net
/// ```
pub fn serve_test(config: &Config, server: &mut dyn Player, serves: u32) -> Result<Rate, Error> {
    let mut game = Badminton::new(config)?;
    let mut rate = Rate::default();
    let mut action = [0.0f32; 3];
    for _ in 0..serves {
        game.set_server(0);
        let turn = game.reset(0);
        if let Some(decision) = turn.decide {
            server.act(Role::Serve, &decision.observation, &mut action);
            game.act(&action);
        }
        if let Some(hit) = game.hits().first() {
            rate.of += 1;
            rate.hits += u32::from(hit.fate.is_fault());
        }
    }
    Ok(rate)
}

/// Catch success with the reset agent enabled and disabled (table 7): `points` points of
/// `player` (seat 0) against `opponent`, each way; returns (enabled, disabled), each the
/// player's catches over its incoming in-balls. Disabled, the player stays where it hit.
pub fn reset_effect(
    config: &Config,
    player: PlayerKind,
    opponent: PlayerKind,
    points: u32,
    seed: u64,
) -> Result<(Rate, Rate), Error> {
    let (player, opponent) = (&player, &opponent);
    let rate = |enabled: bool| -> Result<Rate, Error> {
        let mut game = Badminton::new(config)?;
        game.set_reset_enabled(0, enabled);
        let mut players = [
            player.build(config, seed, 0),
            opponent.build(config, seed, 1),
        ];
        let report = play(&mut game, &mut players, Length::Points(points), |_| {});
        Ok(report.players[0].catches)
    };
    Ok((rate(true)?, rate(false)?))
}

/// The paper's three measures of one player against an opponent: the catch test (catching the
/// opponent's serves), the serve test, and catch success with the reset agent enabled and
/// disabled.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measures {
    /// The player's name.
    pub name: String,
    /// The opponent's name (the server of the catch test, the other side of the reset effect).
    pub opponent: String,
    /// Catch test: its catches of the opponent's in-ball serves.
    pub catches: Rate,
    /// Serve test: its first serves that went out or into the net.
    pub serve_errors: Rate,
    /// Its catches over the incoming in-balls of points against the opponent, reset enabled.
    pub reset_enabled: Rate,
    /// ... and with its reset agent disabled.
    pub reset_disabled: Rate,
    /// The agents that played the safe state (see [`PlayerStats::boot_errors`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub boot_errors: Vec<String>,
}

/// Both players' [`Measures`], as `firmware-sim match --measures` prints and writes them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeasuresReport {
    /// Scenario name.
    pub scenario: String,
    /// Seed of the players' random streams.
    pub seed: u64,
    /// Serves of the catch test and of the serve test.
    pub balls: u32,
    /// Points each way (reset enabled, disabled) of the reset effect.
    pub points: u32,
    /// Player 0 against player 1, and player 1 against player 0.
    pub players: [Measures; 2],
}

/// Measures `player` against `opponent`: the catch test and the serve test over `balls` serves,
/// the reset effect over `points` points each way. Players are built from `seed` as in a match
/// (the measured player in seat 0).
pub fn measure(
    config: &Config,
    player: &PlayerKind,
    opponent: &PlayerKind,
    balls: u32,
    points: u32,
    seed: u64,
) -> Result<Measures, Error> {
    let catches = {
        let mut catcher = player.build(config, seed, 0);
        let mut server = opponent.build(config, seed, 1);
        catch_test(config, catcher.as_mut(), server.as_mut(), balls)?
    };
    let serve_errors = serve_test(config, player.build(config, seed, 0).as_mut(), balls)?;
    let (reset_enabled, reset_disabled) =
        reset_effect(config, player.clone(), opponent.clone(), points, seed)?;
    Ok(Measures {
        name: player.to_string(),
        opponent: opponent.to_string(),
        catches,
        serve_errors,
        reset_enabled,
        reset_disabled,
        boot_errors: player
            .boot_errors()
            .into_iter()
            .map(|(role, e)| format!("{}: {e}", role.name()))
            .collect(),
    })
}

impl MeasuresReport {
    /// Measures each player against the other.
    pub fn of(
        config: &Config,
        kinds: &[PlayerKind; 2],
        balls: u32,
        points: u32,
        seed: u64,
    ) -> Result<MeasuresReport, Error> {
        let [a, b] = kinds;
        Ok(MeasuresReport {
            scenario: config.name.clone(),
            seed,
            balls,
            points,
            players: [
                measure(config, a, b, balls, points, seed)?,
                measure(config, b, a, balls, points, seed)?,
            ],
        })
    }

    /// Whether every agent booted (a measure of a safe state is not the player's).
    pub fn booted(&self) -> bool {
        self.players.iter().all(|p| p.boot_errors.is_empty())
    }

    /// The table `firmware-sim match --measures` prints.
    pub fn summary(&self) -> String {
        let [a, b] = &self.players;
        let mut out = format!(
            "{} | measures of p0 {} and p1 {}, each against the other | seed {}\n",
            self.scenario, a.name, b.name, self.seed
        );
        out.push_str(&format!("  {:<38} {:<22} {}\n", "", "p0", "p1"));
        let rows: [(String, &Rate, &Rate); 4] = [
            (
                format!("catch test ({} serves, in-balls)", self.balls),
                &a.catches,
                &b.catches,
            ),
            (
                format!("serve test ({} serves, out + net)", self.balls),
                &a.serve_errors,
                &b.serve_errors,
            ),
            (
                format!("catch, reset on ({} points)", self.points),
                &a.reset_enabled,
                &b.reset_enabled,
            ),
            (
                format!("catch, reset off ({} points)", self.points),
                &a.reset_disabled,
                &b.reset_disabled,
            ),
        ];
        for (k, x, y) in &rows {
            out.push_str(&format!("  {k:<38} {:<22} {}\n", x.show(), y.show()));
        }
        for (seat, p) in self.players.iter().enumerate() {
            for e in &p.boot_errors {
                let what = "safe state (blob did not boot)";
                out.push_str(&format!("  {what:<38} p{seat} {e}\n"));
            }
        }
        out
    }
}
