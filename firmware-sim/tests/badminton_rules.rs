use firmware_sim::badminton::court::to_own2;
use firmware_sim::badminton::play::{play, play_match, play_point, Length};
use firmware_sim::badminton::player::{action_for_hit, action_for_target};
use firmware_sim::badminton::reference::{Player, PlayerKind};
use firmware_sim::badminton::rules::{game_winner, Cause, Score};
use firmware_sim::badminton::shuttle::{Fate, Physics, Shuttle};
use firmware_sim::badminton::{Badminton, Config, Role};
use firmware_sim::env::{Outcome, Plant, Turn};

/// Plays the decisions of a point from scripted actions: `serve` for every serve, `aim(player,
/// role)` for catch and reset targets (own frame). Returns every outcome closed on the way.
fn run_point(
    game: &mut Badminton,
    serve: [f32; 3],
    aim: impl Fn(usize, Role) -> [f64; 2],
) -> Vec<Outcome> {
    let court = firmware_sim::badminton::court::Court::of(&game.config().court);
    let mut turn: Turn = game.reset(0);
    let mut closed = Vec::new();
    while let Some(d) = turn.decide.take() {
        let (player, role) = Badminton::role_of(d.agent);
        turn = match role {
            Role::Serve => game.act(&serve),
            _ => game.act(&action_for_target(aim(player, role), &court)),
        };
        closed.extend(turn.closed.iter().cloned());
    }
    closed
}

fn outcome(closed: &[Outcome], player: usize, role: Role) -> &Outcome {
    let agent = Badminton::agent(player, role);
    closed
        .iter()
        .rev()
        .find(|o| o.agent == agent)
        .expect("the agent's transition closed")
}

/// A clear from (-2, 0) that lands in the far half, about 3 m behind the receiver's start.
fn clear() -> [f32; 3] {
    action_for_hit(25.0, 50.0, 0.0, &Config::builtin().hit)
}

#[test]
fn a_ball_landing_in_uncaught_is_the_receivers_fault() {
    let mut game = Badminton::new(&Config::builtin()).expect("plant");
    // The receiver runs to the far corner, away from the ball.
    let closed = run_point(&mut game, clear(), |_, _| [-0.5, 2.59]);
    let end = game.point_end().expect("ended");
    assert_eq!(
        (end.winner, end.cause, end.hits),
        (Some(0), Cause::MissedCatch, 1)
    );
    assert_eq!(outcome(&closed, 0, Role::Serve).reward, 1.0);
    let missed = outcome(&closed, 1, Role::Catch);
    assert!(
        missed.terminated && missed.reward > -1.0 && missed.reward < 0.0,
        "{missed:?}"
    );
    assert!(matches!(game.hits()[0].fate, Fate::In(_)) && !game.hits()[0].caught);
    assert_eq!(game.score().points, [1, 0]);
}

#[test]
fn a_receiver_on_the_path_catches_an_in_ball_and_lets_an_out_ball_go() {
    let config = Config::builtin();
    let physics = Physics::of(&config);
    let court = firmware_sim::badminton::court::Court::of(&config.court);
    // Drives from (-2, 0, 1.2) straight down the middle: find one that lands out and one that
    // lands in, both passing within 1 m of (2, 0, 1.2), where the receiver starts.
    let mut out = None;
    let mut inside = None;
    for tenth in 0..300 {
        let elevation = -5.0 + f64::from(tenth) * 0.1;
        for speed in [12.0, 16.0, 20.0, 25.0, 30.0, 40.0, 50.0, 60.0, 77.0] {
            let e = f64::to_radians(elevation);
            let start = Shuttle {
                p: [-2.0, 0.0, 1.2],
                v: [speed * e.cos(), 0.0, speed * e.sin()],
            };
            if !passes_near(&physics, start, [2.0, 0.0, 1.2], 1.0) {
                continue;
            }
            match physics.predict(start, 1.0, &court, 1.2).fate {
                Fate::Out(_) if out.is_none() => out = Some((speed, elevation)),
                Fate::In(_) if inside.is_none() => inside = Some((speed, elevation)),
                _ => {}
            }
        }
    }
    let stand = |_: usize, _: Role| [-2.0, 0.0];
    for (ball, expect_out) in [(out, true), (inside, false)] {
        let (speed, elevation) = ball.expect("such a drive exists");
        let mut game = Badminton::new(&config).expect("plant");
        let serve = action_for_hit(speed, elevation, 0.0, &config.hit);
        let closed = run_point(&mut game, serve, stand);
        let first = game.hits()[0];
        if expect_out {
            assert!(!first.caught, "an out ball is let go");
            let end = game.point_end().expect("ended");
            assert_eq!((end.winner, end.cause), (Some(1), Cause::Out));
            assert_eq!(outcome(&closed, 0, Role::Serve).reward, -1.0);
            assert_eq!(outcome(&closed, 1, Role::Catch).reward, 0.0);
        } else {
            assert!(first.caught, "an in ball on the receiver's path is caught");
            let catch = outcome(&closed, 1, Role::Catch);
            // Caught within the radius: 1 + exp(-d²/(2·1.3²)) with d <= 1.3.
            assert!(catch.reward > 1.6, "{catch:?}");
        }
    }
}

/// Whether the flight passes within `r` of `point` after crossing the net.
fn passes_near(physics: &Physics, mut s: Shuttle, point: [f64; 3], r: f64) -> bool {
    while s.p[2] > 0.0 {
        physics.step(&mut s);
        let d = [s.p[0] - point[0], s.p[1] - point[1], s.p[2] - point[2]];
        if s.p[0] > 0.0 && (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() < r {
            return true;
        }
    }
    false
}

#[test]
fn a_net_ball_is_the_hitters_fault_and_ends_every_open_transition() {
    let mut game = Badminton::new(&Config::builtin()).expect("plant");
    let flat = action_for_hit(10.0, 0.0, 0.0, &game.config().hit);
    let closed = run_point(&mut game, flat, |_, _| [-2.0, 0.0]);
    let end = game.point_end().expect("ended");
    assert_eq!((end.winner, end.cause), (Some(1), Cause::Net));
    assert_eq!(outcome(&closed, 0, Role::Serve).reward, -1.0);
    // The server's reset: no ball comes back, 0 and terminal.
    let reset = outcome(&closed, 0, Role::Reset);
    assert_eq!(
        (reset.reward, reset.terminated, reset.truncated),
        (0.0, true, false)
    );
    assert_eq!(closed.len(), 3);
    assert!(closed.iter().all(|o| o.terminated));
}

/// Scripted players without noise: every clear lands in and is caught.
fn noiseless() -> Config {
    let mut c = Config::builtin();
    c.scripted.catch_noise = 0.0;
    c.scripted.serve_angle_noise = 0.0;
    c
}

#[test]
fn a_rally_reaching_the_cap_is_a_let_and_the_server_serves_again() {
    let mut config = noiseless();
    config.rules.rally_cap = 5;
    let mut game = Badminton::new(&config).expect("plant");
    game.set_server(1);
    let mut players = [0, 1].map(|seat| PlayerKind::Scripted.build(&config, 4, seat));
    let mut closed = Vec::new();
    let mut turn = game.reset(0);
    while let Some(d) = turn.decide.take() {
        let (p, role) = Badminton::role_of(d.agent);
        let mut action = vec![0.0; role.actions()];
        players[p].act(role, &d.observation, &mut action);
        turn = game.act(&action);
        closed.extend(turn.closed.iter().cloned());
    }
    let end = game.point_end().expect("ended");
    assert_eq!((end.winner, end.cause, end.hits), (None, Cause::Let, 5));
    assert!(game.hits().iter().all(|h| h.caught));
    let last: Vec<&Outcome> = closed.iter().rev().take(6).collect();
    assert!(
        last.iter().all(|o| o.truncated && !o.terminated),
        "{last:?}"
    );
    assert_eq!(
        game.score(),
        Score {
            server: 1,
            ..Score::new()
        }
    );
    let next = game.reset(0).decide.expect("a new point");
    assert_eq!(Badminton::role_of(next.agent), (1, Role::Serve));
}

#[test]
fn games_end_at_11_9_12_10_and_20_19() {
    let rules = Config::builtin().rules;
    for (points, winner) in [
        ([11, 9], Some(0)),
        ([9, 11], Some(1)),
        ([11, 10], None),
        ([12, 10], Some(0)),
        ([13, 12], None),
        ([19, 19], None),
        ([20, 19], Some(0)),
        ([19, 20], Some(1)),
        ([10, 8], None),
    ] {
        assert_eq!(game_winner(points, &rules), winner, "{points:?}");
    }
    // Played point by point: 10-10, then 11-10 goes on, 12-10 ends.
    let mut score = Score::new();
    for p in [0, 1].repeat(10) {
        assert_eq!(score.point(p, &rules), None);
    }
    assert_eq!(score.point(0, &rules), None);
    assert_eq!(score.point(0, &rules), Some(0));
    // 19-19, then 20-19 ends however small the lead.
    let mut score = Score::new();
    for p in [0, 1].repeat(19) {
        score.point(p, &rules);
    }
    assert_eq!(score.points, [19, 19]);
    assert_eq!(score.point(1, &rules), Some(1));
}

#[test]
fn the_point_winner_serves_next_and_the_game_winner_first_in_the_next_game() {
    let rules = Config::builtin().rules;
    let mut score = Score::new();
    assert_eq!(score.server, 0);
    score.point(1, &rules);
    assert_eq!(score.server, 1);
    score.point(0, &rules);
    assert_eq!(score.server, 0);
    // Player 1 wins the game with its last point from 10-9; then it serves first.
    let mut score = Score::new();
    for p in [0, 1].repeat(9) {
        score.point(p, &rules);
    }
    score.point(1, &rules);
    score.point(0, &rules);
    score.point(1, &rules);
    score.point(1, &rules);
    assert_eq!(
        (score.games, score.points, score.server),
        ([0, 1], [0, 0], 1)
    );
    // In the plant: the winner of a point is the next server.
    let mut game = Badminton::new(&Config::builtin()).expect("plant");
    let flat = action_for_hit(10.0, 0.0, 0.0, &game.config().hit);
    run_point(&mut game, flat, |_, _| [-2.0, 0.0]);
    let next = game.reset(0).decide.expect("decision");
    assert_eq!(Badminton::role_of(next.agent), (1, Role::Serve));
}

/// Records (agent, observation) at every decision of a point between scripted players.
fn decisions(game: &mut Badminton, players: &mut [Box<dyn Player>; 2]) -> Vec<(usize, Vec<f32>)> {
    let mut seen = Vec::new();
    let mut turn = game.reset(0);
    while let Some(d) = turn.decide.take() {
        let (p, role) = Badminton::role_of(d.agent);
        let mut action = vec![0.0; role.actions()];
        players[p].act(role, &d.observation, &mut action);
        seen.push((d.agent, d.observation));
        turn = game.act(&action);
    }
    seen
}

#[test]
fn a_rally_mirrored_through_the_turn_gives_the_mirrored_observations() {
    let config = Config::builtin();
    // Rally A: player 0 serves. Rally B: the same two players in swapped seats, player 1 serves.
    let mut a = Badminton::new(&config).expect("plant");
    a.record_rallies(true);
    let mut seats_a = [0, 1].map(|s| PlayerKind::Scripted.build(&config, 9, s));
    let seen_a = decisions(&mut a, &mut seats_a);
    let mut b = Badminton::new(&config).expect("plant");
    b.record_rallies(true);
    b.set_server(1);
    let [x, y] = [0, 1].map(|s| PlayerKind::Scripted.build(&config, 9, s));
    let mut seats_b = [y, x];
    let seen_b = decisions(&mut b, &mut seats_b);
    assert!(seen_a.len() > 6, "a real rally: {} decisions", seen_a.len());
    assert_eq!(seen_a.len(), seen_b.len());
    for ((agent_a, obs_a), (agent_b, obs_b)) in seen_a.iter().zip(&seen_b) {
        let (pa, ra) = Badminton::role_of(*agent_a);
        assert_eq!(Badminton::role_of(*agent_b), (1 - pa, ra));
        assert_eq!(obs_a, obs_b, "the same view from the mirrored seat");
    }
    let (ra, rb) = (a.rally().expect("recorded"), b.rally().expect("recorded"));
    assert_eq!(ra.shuttle.len(), rb.shuttle.len());
    for (p, q) in ra.shuttle.iter().zip(&rb.shuttle) {
        assert_eq!([-p[0], -p[1], p[2]], *q);
    }
    let (ea, eb) = (a.point_end().expect("end"), b.point_end().expect("end"));
    assert_eq!(
        (ea.cause, ea.hits, ea.winner.map(|w| 1 - w)),
        (eb.cause, eb.hits, eb.winner)
    );
}

#[test]
fn players_stay_in_their_halves_at_their_speed_limit_in_random_play() {
    let config = Config::builtin();
    let mut game = Badminton::new(&config).expect("plant");
    game.record_rallies(true);
    let mut players = [0, 1].map(|s| PlayerKind::Random.build(&config, 3, s));
    let step = 10.0 * config.shuttle.dt * config.player.max_speed;
    for _ in 0..200 {
        play_point(&mut game, &mut players);
        let rally = game.rally().expect("recorded");
        for (p, pair) in [0, 1]
            .iter()
            .flat_map(|p| rally.players.windows(2).map(move |w| (*p, w)))
        {
            let (a, b) = (to_own2(p, pair[0][p]), to_own2(p, pair[1][p]));
            assert!(
                (-6.7..=0.0).contains(&b[0]) && b[1].abs() <= 2.59,
                "player {p} at {b:?}"
            );
            assert!((b[0] - a[0]).hypot(b[1] - a[1]) <= step * (1.0 + 1e-12));
        }
    }
}

#[test]
fn the_same_seed_gives_the_same_match_bit_for_bit() {
    let config = Config::builtin();
    let kinds = [PlayerKind::Scripted, PlayerKind::Scripted];
    let run =
        |seed| play_match(&config, &kinds, Length::Games(1), seed, false, |_| {}).expect("match");
    let (a, b) = (run(5), run(5));
    assert_eq!(a, b);
    assert_eq!(
        serde_json::to_string(&a).ok(),
        serde_json::to_string(&b).ok()
    );
    assert_ne!(a, run(6));
}

#[test]
fn with_the_reset_disabled_the_player_stays_where_it_hit() {
    let config = noiseless();
    let mut game = Badminton::new(&config).expect("plant");
    game.set_reset_enabled(0, false);
    let mut players = [0, 1].map(|s| PlayerKind::Scripted.build(&config, 1, s));
    let report = play(&mut game, &mut players, Length::Points(3), |_| {});
    assert_eq!(report.points, 3);
    // Step by step: after player 0's serve, the next decision is player 1's catch, and player 0
    // does not move during the flight.
    game.set_server(0);
    let turn = game.reset(0);
    let start = game.bodies()[0].position;
    let serve = turn.decide.expect("serve");
    let mut action = [0.0; 3];
    players[0].act(Role::Serve, &serve.observation, &mut action);
    let turn = game.act(&action);
    assert_eq!(
        Badminton::role_of(turn.decide.expect("catch").agent),
        (1, Role::Catch)
    );
    game.act(&[1.0, 1.0]);
    assert_eq!(game.bodies()[0].position, start);
}

/// Two players who never miss let every point: a match of games must still end (after
/// 4 · point_cap points a game), and its let rate fails the pass criteria.
#[test]
fn a_match_of_lets_ends_and_fails() {
    let config = noiseless();
    let kinds = [PlayerKind::Scripted, PlayerKind::Scripted];
    let r = play_match(&config, &kinds, Length::Games(1), 0, false, |_| {}).expect("match");
    assert_eq!((r.points, r.lets, r.games), (80, 80, [0, 0]));
    assert!(!r.pass.passed);
    assert!(
        r.pass
            .failures
            .iter()
            .any(|f| f.starts_with("let rate 1.000")),
        "{:?}",
        r.pass
    );
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Any value in any numeric field of `badminton.toml`: a one-line error, or a scenario whose
    /// plant plays points to their end (no panic, no endless flight).
    #[test]
    fn any_value_in_the_scenario_is_refused_in_one_line_or_plays(
        field in 0usize..40,
        value in proptest::sample::select(vec![
            "0", "-1", "1e-300", "1e-9", "0.5", "3", "200", "1e300", "nan", "inf", "-inf", "[1.0]",
        ]),
    ) {
        let lines: Vec<&str> = Config::BUILTIN.lines().collect();
        let numeric: Vec<usize> = (0..lines.len())
            .filter(|&i| lines[i].contains(" = ") && !lines[i].contains('"'))
            .collect();
        let target = numeric[field % numeric.len()];
        let key = lines[target].split(" = ").next().unwrap_or_default();
        let mut text: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        text[target] = format!("{key} = {value}");
        match Config::from_toml_str(&text.join("\n"), "fuzzed.toml") {
            Err(e) => {
                let e = e.to_string();
                proptest::prop_assert!(e.starts_with("fuzzed.toml") && e.lines().count() == 1, "{e}");
            }
            Ok(config) => {
                let mut game = Badminton::new(&config).expect("a valid scenario builds");
                let mut players = [0, 1].map(|s| PlayerKind::Random.build(&config, 1, s));
                for _ in 0..3 {
                    play_point(&mut game, &mut players);
                }
            }
        }
    }
}

/// The ground truth of each closed transition says whether the agent's player stood on a margin
/// (a line or the net) during it.
#[test]
fn a_player_sent_to_the_net_is_reported_at_a_margin() {
    let mut game = Badminton::new(&Config::builtin()).expect("plant");
    // The receiver runs to the net (x' = 0) and misses the clear; the server resets inside.
    let closed = run_point(&mut game, clear(), |player, _| {
        if player == 1 {
            [0.0, 0.0]
        } else {
            [-3.0, 0.0]
        }
    });
    assert_eq!(game.point_end().map(|e| e.cause), Some(Cause::MissedCatch));
    assert!(outcome(&closed, 1, Role::Catch).margin_touched);
    assert!(!outcome(&closed, 0, Role::Reset).margin_touched);
    assert!(!outcome(&closed, 0, Role::Serve).margin_touched);
}

/// The interface's contract for learners, over many points: an agent's transition closes
/// exactly once, at its next decision (with that decision's observation, neither terminal nor
/// truncated) or at the end of the point (terminal at a dead ball, truncated at a let); nothing
/// closes that was not open.
#[test]
fn every_transition_closes_exactly_once() {
    let mut config = Config::builtin();
    config.rules.rally_cap = 6; // some lets among the points
    let mut game = Badminton::new(&config).expect("plant");
    let mut players = [0, 1].map(|s| PlayerKind::Scripted.build(&config, 8, s));
    let (mut lets, mut faults, mut transitions) = (0, 0, 0);
    for point in 0..300 {
        let mut open = [false; 6];
        let mut turn = game.reset(0);
        while let Some(d) = turn.decide.take() {
            let (p, role) = Badminton::role_of(d.agent);
            let mut action = vec![0.0; role.actions()];
            players[p].act(role, &d.observation, &mut action);
            open[d.agent] = true;
            turn = game.act(&action);
            let end = game.point_end();
            for o in &turn.closed {
                assert!(
                    open[o.agent],
                    "agent {} closed without an open transition",
                    o.agent
                );
                open[o.agent] = false;
                transitions += 1;
                match (&turn.decide, end) {
                    (Some(next), None) => {
                        assert_eq!(o.agent, next.agent, "only the deciding agent closes");
                        assert_eq!(o.observation, next.observation);
                        assert!(!o.terminated && !o.truncated);
                    }
                    (None, Some(e)) => {
                        let is_let = e.cause == Cause::Let;
                        assert_eq!((o.terminated, o.truncated), (!is_let, is_let));
                    }
                    other => panic!("a turn either names a decision or ends: {other:?}"),
                }
            }
        }
        assert_eq!(
            open, [false; 6],
            "point {point}: every open transition closed at the end"
        );
        let is_let = game.point_end().is_some_and(|e| e.cause == Cause::Let);
        lets += usize::from(is_let);
        faults += usize::from(!is_let);
    }
    let counts = format!("{lets} lets, {faults} faults, {transitions} transitions");
    assert!(lets > 10 && faults > 10 && transitions > 1000, "{counts}");
}
