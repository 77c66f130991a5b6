//! A team's training loop: N badminton players of three learners each (catch, serve, reset),
//! random pairings within the team, one point per episode.
//!
//! The loop drives firmware-sim's [`Plant`] interface, which is built for agents that act at
//! events: after a reset or an action the plant names the agent that decides next and hands
//! back the transitions that closed since (an agent's transition runs from one of its own
//! decisions to its next, or to the dead ball). Each agent is an ordinary learner of the
//! chosen algorithm ([`Learner`]: its own networks, replay or rollout, normaliser and random
//! streams), fed exactly the transitions the plant closes for it, so navigation's single agent
//! and a badminton player's three learn through the same [`crate::algorithms::algorithm::Algorithm`]
//! calls. A closed transition is learnt before its agent acts again (the plant closes it in the
//! turn where that agent decides).
//!
//! Per point: two distinct players drawn uniformly from the team (the first serves or receives
//! by a fair draw), one exploration σ from U[sigma_min, sigma_max] for all six learners of the
//! game \[paper\], then the point played to its end. Every draw comes from the team's stream
//! `team` of the seed; learner k of player p seeds its own streams from stream `learner`
//! index 3p + k, so teams of DCP with T = 1, 4 and 16 and the same seed start from the same
//! weights.

use rand_core::Rng;
use serde::{Deserialize, Serialize};

use firmware_sim::badminton;
use firmware_sim::badminton::game::{Badminton, Role};
use firmware_sim::badminton::shuttle::Fate;
use firmware_sim::env::Plant;
use firmware_sim::seed::{self, uniform_f32, SimRng};

use super::config::TeamConfig;
use crate::algorithms::algorithm::Step;
use crate::algorithms::Learner;
use crate::Error;

/// One player: a learner per role, in [`Role::ALL`]'s order.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Player {
    /// Catch, serve and reset learners.
    pub agents: Vec<Learner>,
    /// Transitions each agent has learnt from (its own step count).
    pub steps: [u64; 3],
    /// Points the player has played.
    pub points: u64,
}

/// Sums over a block of points, for one row of `metrics.csv`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Tally {
    /// Points played.
    pub points: u64,
    /// Hits (serves and returns).
    pub hits: u64,
    /// Points cut by the rally cap.
    pub lets: u64,
    /// Hits that went out or into the net.
    pub faults: u64,
    /// Balls that landed in the receiver's half or were caught on the way.
    pub in_balls: u64,
    /// Of those, caught.
    pub caught: u64,
    /// Reward summed per role.
    pub reward: [f64; 3],
    /// Transitions per role.
    pub transitions: [u64; 3],
    /// Per role, the sums and counts of each learner statistic (the algorithm's columns).
    pub stats: [Vec<(f64, u64)>; 3],
}

/// One row of `metrics.csv`: the means of one block of points.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BlockRow {
    /// Points of the team so far, this block's included.
    pub points: usize,
    /// The block's tally.
    pub tally: Tally,
}

/// The whole training state of a team.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Team {
    /// The players.
    pub players: Vec<Player>,
    /// Points played so far.
    pub points: usize,
    /// Pairings, servers and σ draws.
    #[serde(with = "crate::rng_state::serde_rng")]
    rng: SimRng,
    /// Completed blocks.
    pub rows: Vec<BlockRow>,
    /// The block under way.
    pub tally: Tally,
}

/// The seed of learner `role` of player `player` in a team seeded with `seed`.
pub fn learner_seed(seed: u64, player: usize, role: usize) -> u64 {
    seed::stream(seed, "learner", (3 * player + role) as u64).next_u64()
}

impl Team {
    /// A fresh team: every learner initialised from its own seed ([`learner_seed`]).
    pub fn new(config: &TeamConfig, plant: &badminton::Config) -> Result<Team, Error> {
        config.validate()?;
        let specs = Badminton::new(plant).map_err(plant_error)?.agents();
        let players = (0..config.players)
            .map(|p| {
                let agents = (0..3)
                    .map(|r| {
                        let spec = &specs[r];
                        let sections = config.sections(learner_seed(config.seed, p, r));
                        let space = &spec.action_space;
                        let obs = spec.observation_space.dim();
                        Learner::new(&sections, obs, &space.low, &space.high)
                    })
                    .collect::<Result<Vec<_>, Error>>()?;
                Ok(Player {
                    agents,
                    steps: [0; 3],
                    points: 0,
                })
            })
            .collect::<Result<Vec<_>, Error>>()?;
        Ok(Team {
            players,
            points: 0,
            rng: seed::training_stream(config.seed, "team"),
            rows: Vec::new(),
            tally: Tally::default(),
        })
    }

    /// Sets every learner's settings from the config after a checkpoint load.
    pub fn configure(&mut self, config: &TeamConfig) -> Result<(), String> {
        if config.players != self.players.len() {
            return Err(format!(
                "the config has {} players and the checkpoint {}",
                config.players,
                self.players.len()
            ));
        }
        for (p, player) in self.players.iter_mut().enumerate() {
            for (r, learner) in player.agents.iter_mut().enumerate() {
                learner.configure(&config.sections(learner_seed(config.seed, p, r)))?;
            }
        }
        Ok(())
    }

    /// Plays and learns one point between two players drawn from the team.
    pub fn play_point(&mut self, config: &TeamConfig, game: &mut Badminton) -> Result<(), Error> {
        let n = self.players.len() as u64;
        let first = self.rng.next_u64() % n;
        let second = (first + 1 + self.rng.next_u64() % (n - 1)) % n;
        let pair = [first as usize, second as usize];
        let sigma =
            config.sigma_min + (config.sigma_max - config.sigma_min) * uniform_f32(&mut self.rng);
        game.new_match();
        game.set_server((self.rng.next_u32() & 1) as usize);
        for &p in &pair {
            let player = &mut self.players[p];
            for learner in &mut player.agents {
                let algorithm = learner.algorithm();
                algorithm.set_exploration_sigma(Some(sigma));
                algorithm.start_episode(player.points as usize, config.points);
            }
        }
        let mut decided: [Vec<f32>; 6] = Default::default();
        let mut turn = game.reset(0);
        loop {
            for o in &turn.closed {
                let (slot, role) = Badminton::role_of(o.agent);
                let r = role_index(role);
                let player = &mut self.players[pair[slot]];
                player.steps[r] += 1;
                let step = Step {
                    obs: &decided[o.agent],
                    reward: o.reward,
                    next_obs: &o.observation,
                    terminated: o.terminated,
                    truncated: o.truncated,
                    total_steps: player.steps[r],
                };
                player.agents[r]
                    .algorithm()
                    .learn(&step)
                    .map_err(|what| diverged(self.points, pair[slot], role, what))?;
                self.tally.reward[r] += f64::from(o.reward);
                self.tally.transitions[r] += 1;
            }
            let Some(decision) = turn.decide else { break };
            let (slot, role) = Badminton::role_of(decision.agent);
            let learner = &mut self.players[pair[slot]].agents[role_index(role)];
            let action = learner.algorithm().act(&decision.observation);
            decided[decision.agent] = decision.observation;
            turn = game.act(&action);
        }
        self.count_point(game, pair);
        self.points += 1;
        Ok(())
    }

    /// Adds the point just played to the block's tally, and each learner's statistics.
    fn count_point(&mut self, game: &Badminton, pair: [usize; 2]) {
        let t = &mut self.tally;
        t.points += 1;
        if let Some(end) = game.point_end() {
            t.lets += u64::from(end.winner.is_none());
        }
        for hit in game.hits() {
            t.hits += 1;
            t.faults += u64::from(hit.fate.is_fault());
            if let Fate::In(_) = hit.fate {
                t.in_balls += 1;
                t.caught += u64::from(hit.caught);
            }
        }
        for &p in &pair {
            let player = &mut self.players[p];
            player.points += 1;
            for (r, learner) in player.agents.iter_mut().enumerate() {
                let values = learner.algorithm().episode_stats();
                let sums = &mut t.stats[r];
                sums.resize(values.len(), (0.0, 0));
                for (s, v) in sums.iter_mut().zip(values) {
                    if !v.is_nan() {
                        *s = (s.0 + f64::from(v), s.1 + 1);
                    }
                }
            }
        }
    }

    /// Closes the block under way into a row of the metrics.
    pub fn close_block(&mut self) {
        let tally = std::mem::take(&mut self.tally);
        self.rows.push(BlockRow {
            points: self.points,
            tally,
        });
    }

    /// Whether every learner's weights are finite.
    pub fn is_finite(&self) -> bool {
        (self.players.iter()).all(|p| p.agents.iter().all(|l| l.get().is_finite()))
    }
}

/// The position of a role in [`Role::ALL`].
pub fn role_index(role: Role) -> usize {
    match role {
        Role::Catch => 0,
        Role::Serve => 1,
        Role::Reset => 2,
    }
}

fn diverged(points: usize, player: usize, role: Role, what: &'static str) -> Error {
    Error::Diverged {
        episode: points + 1,
        what: format!("player {player} {} {what}", role.name()),
        checkpoint: None,
    }
}

/// A badminton scenario that does not make a plant.
pub fn plant_error(e: firmware_sim::Error) -> Error {
    Error::InvalidConfig {
        what: "scenario".into(),
        expected: "a badminton scenario firmware-sim accepts".into(),
        found: e.to_string(),
    }
}
