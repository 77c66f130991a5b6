//! The badminton plant: two players of three agents each, one point per episode.
//!
//! Decision points (docs/design.md §3): the server's *serve* agent at the start of a point;
//! after every hit, the hitter's *reset* agent and then the receiver's *catch* agent; at a
//! catch, the catcher's *serve* agent. Between them the plant runs the physics at `dt`: the
//! shuttle, both players moving toward their targets, the net, the floor, the catch. Rewards
//! are credited to the agents as flights resolve and handed over when each agent's transition
//! closes (at its next decision, or at the dead ball: terminal; at a let: truncated).
//!
//! ```
//! use firmware_sim::badminton::{Badminton, Config, Role};
//! use firmware_sim::env::Plant;
//! let mut game = Badminton::new(&Config::builtin()).unwrap();
//! let turn = game.reset(0);
//! let first = turn.decide.unwrap();
//! assert_eq!(Badminton::role_of(first.agent), (0, Role::Serve)); // player 0 serves first
//! // A serve straight into the floor at 3 m/s: the hitter's own side, a net ball.
//! game.act(&[-1.0, -1.0, 0.0]);            // serve
//! game.act(&[0.0, 0.0]);                   // player 0's reset
//! let end = game.act(&[0.0, 0.0]);         // player 1's catch; the ball dies
//! assert!(end.decide.is_none());
//! let serve = end.closed.iter().find(|o| o.agent == first.agent).unwrap();
//! assert_eq!((serve.reward, serve.terminated), (-1.0, true));
//! assert_eq!(game.score().points, [0, 1]);
//! ```

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use super::config::Config;
use super::court::{distance, squared_distance, to_own, to_own2, Court, Vec2, Vec3};
use super::player::{hit_velocity, target_of, unit, Body};
use super::rules::{Cause, PointEnd, Score};
use super::shuttle::{Event, Fate, Flight, Physics, Shuttle};
use crate::env::{AgentSpec, BoxSpace, Decision, Outcome, Plant, StepInfo, Turn};
use crate::Error;

/// Observation size of every agent: shuttle position and velocity, own position, opponent
/// position, all in the player's own frame.
pub const OBSERVATIONS: usize = 10;

/// The three agents of a player.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Role {
    /// Where to stand for the incoming ball (2 actions).
    Catch,
    /// The hit velocity (3 actions).
    Serve,
    /// Where to go after the own hit (2 actions).
    Reset,
}

impl Role {
    /// The three roles in agent order.
    pub const ALL: [Role; 3] = [Role::Catch, Role::Serve, Role::Reset];

    /// Action size.
    pub fn actions(self) -> usize {
        match self {
            Role::Serve => 3,
            Role::Catch | Role::Reset => 2,
        }
    }

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Role::Catch => "catch",
            Role::Serve => "serve",
            Role::Reset => "reset",
        }
    }
}

/// One hit of a rally and how its flight ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Who hit.
    pub hitter: usize,
    /// Where the shuttle started and its velocity, world frame.
    pub launch: Shuttle,
    /// How the flight ends if nobody catches it (known to the plant at the hit).
    pub fate: Fate,
    /// The receiver caught it.
    pub caught: bool,
}

/// A rally recorded for drawing: samples every `every` physics steps.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rally {
    /// Shuttle positions, world frame.
    pub shuttle: Vec<Vec3>,
    /// Both players' floor positions, world frame, at the same instants.
    pub players: Vec<[Vec2; 2]>,
    /// Index into the samples at each hit, and who hit.
    pub hits: Vec<(usize, usize)>,
    /// How the point ended.
    pub end: Option<PointEnd>,
}

/// The plant.
#[derive(Clone, Debug)]
pub struct Badminton {
    config: Config,
    court: Court,
    physics: Physics,
    agents: Vec<AgentSpec>,
    bodies: [Body; 2],
    shuttle: Shuttle,
    flight: Flight,
    fate: Fate,
    hitter: usize,
    hits: u32,
    queue: VecDeque<usize>,
    open: [bool; 6],
    earned: [f64; 6],
    /// Physics steps each player has stood on a margin, and the count when each agent decided.
    on_margin_steps: [u64; 2],
    on_margin_at_open: [u64; 6],
    reset_enabled: [bool; 2],
    score: Score,
    log: Vec<Hit>,
    end: Option<PointEnd>,
    steps: u64,
    rally: Option<Rally>,
}

/// Steps between two samples of a recorded rally (10 ms at the shipped `dt`).
const SAMPLE_EVERY: u64 = 10;

impl Badminton {
    /// The plant of a scenario, 0–0 with player 0 to serve.
    pub fn new(config: &Config) -> Result<Badminton, Error> {
        config.validate()?;
        let court = Court::of(&config.court);
        let start = to_own2(0, config.player.start);
        Ok(Badminton {
            agents: agent_specs(config),
            physics: Physics::of(config),
            bodies: [Body::at(start), Body::at(to_own2(1, config.player.start))],
            shuttle: Shuttle {
                p: [start[0], start[1], config.player.hit_height],
                v: [0.0; 3],
            },
            flight: Flight::by(0),
            fate: Fate::Net,
            hitter: 0,
            hits: 0,
            queue: VecDeque::with_capacity(2),
            open: [false; 6],
            earned: [0.0; 6],
            on_margin_steps: [0; 2],
            on_margin_at_open: [0; 6],
            reset_enabled: [true; 2],
            score: Score::new(),
            log: Vec::new(),
            end: None,
            steps: 0,
            rally: None,
            court,
            config: config.clone(),
        })
    }

    /// The agent index of a player's role (`player · 3 + role`).
    pub fn agent(player: usize, role: Role) -> usize {
        player * 3 + role as usize
    }

    /// The player and role of an agent index.
    pub fn role_of(agent: usize) -> (usize, Role) {
        (agent / 3, Role::ALL[agent % 3])
    }

    /// The scenario.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The score of the match so far.
    pub fn score(&self) -> Score {
        self.score
    }

    /// Starts a new match: 0–0, player 0 to serve (the next [`Plant::reset`] starts its first
    /// point).
    pub fn new_match(&mut self) {
        self.score = Score::new();
    }

    /// Makes `player` serve the next point (for tests and the paper's measures).
    pub fn set_server(&mut self, player: usize) {
        self.score.server = player.min(1);
    }

    /// With `false`, the player's reset agent never decides: after a hit the player stays where
    /// it hit (the paper's table 7).
    pub fn set_reset_enabled(&mut self, player: usize, on: bool) {
        self.reset_enabled[player.min(1)] = on;
    }

    /// Records the next points' rallies for drawing ([`Badminton::rally`]).
    pub fn record_rallies(&mut self, on: bool) {
        self.rally = on.then(Rally::default);
    }

    /// The current (or last) point's recorded rally.
    pub fn rally(&self) -> Option<&Rally> {
        self.rally.as_ref()
    }

    /// The hits of the current (or last) point.
    pub fn hits(&self) -> &[Hit] {
        &self.log
    }

    /// How the current point ended, once it has.
    pub fn point_end(&self) -> Option<PointEnd> {
        self.end
    }

    /// Physics steps run since the plant was built.
    pub fn physics_steps(&self) -> u64 {
        self.steps
    }

    /// The shuttle, world frame.
    pub fn shuttle(&self) -> Shuttle {
        self.shuttle
    }

    /// Both players' floor positions and targets, world frame.
    pub fn bodies(&self) -> [Body; 2] {
        self.bodies
    }

    /// Player `player`'s observation: shuttle position and velocity, own position, opponent
    /// position, in its own frame.
    pub fn observation(&self, player: usize) -> Vec<f32> {
        let p = to_own(player, self.shuttle.p);
        let v = to_own(player, self.shuttle.v);
        let own = to_own2(player, self.bodies[player].position);
        let other = to_own2(player, self.bodies[1 - player].position);
        [
            p[0], p[1], p[2], v[0], v[1], v[2], own[0], own[1], other[0], other[1],
        ]
        .map(|x| x as f32)
        .to_vec()
    }

    fn hit_point(&self, player: usize) -> Vec3 {
        let p = self.bodies[player].position;
        [p[0], p[1], self.config.player.hit_height]
    }

    /// The serve agent of `player` hits: from where the shuttle is, at the velocity asked.
    fn hit(&mut self, player: usize, action: &[f32]) -> StepInfo {
        let v = to_own(player, hit_velocity(action, &self.config.hit));
        self.shuttle.v = v;
        self.hitter = player;
        self.hits += 1;
        self.flight = Flight::by(player);
        let side = self.flight.side;
        let h = self.config.player.hit_height;
        self.fate = self
            .physics
            .predict(self.shuttle, side, &self.court, h)
            .fate;
        self.log.push(Hit {
            hitter: player,
            launch: self.shuttle,
            fate: self.fate,
            caught: false,
        });
        if let Some(rally) = &mut self.rally {
            rally.hits.push((rally.shuttle.len(), player));
            rally.shuttle.push(self.shuttle.p);
            rally.players.push(self.bodies.map(|b| b.position));
        }
        if self.reset_enabled[player] {
            self.queue.push_back(Self::agent(player, Role::Reset));
        } else {
            self.bodies[player].target = self.bodies[player].position;
        }
        self.queue.push_back(Self::agent(1 - player, Role::Catch));
        StepInfo {
            applied: (0..3).map(|i| unit(action, i) as f32).collect(),
            margin_touched: false,
            success: None,
        }
    }

    /// A catch or reset agent picks its target.
    fn aim(&mut self, player: usize, action: &[f32]) -> StepInfo {
        let target = target_of(action, &self.court);
        self.bodies[player].target = to_own2(player, target);
        StepInfo {
            applied: target.iter().map(|&c| c as f32).collect(),
            margin_touched: self.court.on_margin(target),
            success: None,
        }
    }

    /// Runs the physics until the receiver catches the shuttle or the ball is dead.
    fn fly(&mut self) {
        let receiver = 1 - self.hitter;
        let radius = self.config.player.catch_radius;
        let lets_go = self.fate.is_fault();
        let max_speed = self.config.player.max_speed;
        // Squared distances, with one square root at the end: the minimum commutes with the
        // (monotone) square root, and the catch test takes the root only near the radius, so
        // the result is what the distances themselves give.
        let near = (radius * (1.0 + 1e-9)).powi(2);
        let mut closest = f64::INFINITY;
        loop {
            let before = self.shuttle;
            self.physics.step(&mut self.shuttle);
            for body in &mut self.bodies {
                body.advance(max_speed, self.physics.dt);
            }
            self.count_margins();
            self.steps += 1;
            self.sample();
            let reach = self.hit_point(receiver);
            if let Event::Ended(fate, at) = self.flight.advance(&before, &self.shuttle, &self.court)
            {
                self.dead(fate, closest.sqrt().min(distance(at, reach)));
                return;
            }
            let d2 = squared_distance(self.shuttle.p, reach);
            closest = closest.min(d2);
            if self.flight.crossed && !lets_go && d2 <= near && d2.sqrt() <= radius {
                self.caught(closest.sqrt());
                return;
            }
        }
    }

    fn sample(&mut self) {
        if self.steps % SAMPLE_EVERY != 0 {
            return;
        }
        if let Some(rally) = &mut self.rally {
            rally.shuttle.push(self.shuttle.p);
            rally.players.push(self.bodies.map(|b| b.position));
        }
    }

    /// The catch reward of docs/design.md §3, eq. 18 (without its miss/catch term): the closer the
    /// shuttle came to the hitting point, the nearer to 1.
    fn closeness(&self, closest: f64) -> f64 {
        let r = self.config.player.catch_radius;
        (-closest * closest / (2.0 * r * r)).exp()
    }

    fn credit(&mut self, agent: usize, reward: f64) {
        if self.open[agent] {
            self.earned[agent] += reward;
        }
    }

    /// Credits a catch reward to the receiver's catch agent and to its reset agent (whose reward
    /// is the catch reward of the next incoming ball).
    fn credit_catch(&mut self, receiver: usize, reward: f64) {
        self.credit(Self::agent(receiver, Role::Catch), reward);
        self.credit(Self::agent(receiver, Role::Reset), reward);
    }

    fn dead(&mut self, fate: Fate, closest: f64) {
        let (hitter, receiver) = (self.hitter, 1 - self.hitter);
        let serve = Self::agent(hitter, Role::Serve);
        let (winner, cause) = match fate {
            Fate::Out(_) => (receiver, Cause::Out),
            Fate::Net => (receiver, Cause::Net),
            Fate::In(_) => (hitter, Cause::MissedCatch),
        };
        if fate.is_fault() {
            self.credit(serve, -1.0);
        } else {
            self.credit(serve, 1.0);
            self.credit_catch(receiver, -1.0 + self.closeness(closest));
        }
        self.finish(PointEnd {
            winner: Some(winner),
            cause,
            hits: self.hits,
        });
    }

    fn caught(&mut self, closest: f64) {
        let receiver = 1 - self.hitter;
        self.credit_catch(receiver, 1.0 + self.closeness(closest));
        if let Some(hit) = self.log.last_mut() {
            hit.caught = true;
        }
        if self.hits >= self.config.rules.rally_cap {
            self.finish(PointEnd {
                winner: None,
                cause: Cause::Let,
                hits: self.hits,
            });
        } else {
            self.queue.push_back(Self::agent(receiver, Role::Serve));
        }
    }

    fn finish(&mut self, end: PointEnd) {
        self.score.record(&end, &self.config.rules);
        self.end = Some(end);
        if let Some(rally) = &mut self.rally {
            rally.end = Some(end);
        }
    }

    /// The transition of `agent` closes now with this observation.
    fn close(&mut self, agent: usize, observation: Vec<f32>, end: Option<&PointEnd>) -> Outcome {
        self.open[agent] = false;
        let let_ = end.is_some_and(|e| e.cause == Cause::Let);
        Outcome {
            agent,
            reward: std::mem::take(&mut self.earned[agent]) as f32,
            observation,
            terminated: end.is_some() && !let_,
            truncated: let_,
            margin_touched: self.on_margin_steps[agent / 3] > self.on_margin_at_open[agent],
        }
    }

    /// Counts the steps each player stands on a line or at the net (the margins of its motion).
    fn count_margins(&mut self) {
        for (p, body) in self.bodies.iter().enumerate() {
            let own = to_own2(p, body.position);
            self.on_margin_steps[p] += u64::from(self.court.on_margin(own));
        }
    }

    /// What the agents are told after a reset or an action.
    fn turn(&mut self, info: StepInfo, ended_now: bool) -> Turn {
        let mut closed = Vec::new();
        if ended_now {
            let end = self.end;
            for agent in 0..6 {
                if self.open[agent] {
                    let obs = self.observation(agent / 3);
                    closed.push(self.close(agent, obs, end.as_ref()));
                }
            }
            return Turn {
                decide: None,
                closed,
                info,
            };
        }
        let decide = self.queue.front().map(|&agent| Decision {
            agent,
            observation: self.observation(agent / 3),
        });
        if let Some(d) = &decide {
            if self.open[d.agent] {
                closed.push(self.close(d.agent, d.observation.clone(), None));
            }
        }
        Turn {
            decide,
            closed,
            info,
        }
    }
}

impl Plant for Badminton {
    fn agents(&self) -> Vec<AgentSpec> {
        self.agents.clone()
    }

    /// Starts the next point of the match: both players at their start, the shuttle at the
    /// server's hitting point. The plant has no randomness of its own (the players do), so the
    /// seed does not matter.
    fn reset(&mut self, _seed: u64) -> Turn {
        let server = self.score.server;
        let start = self.config.player.start;
        self.bodies = [Body::at(to_own2(0, start)), Body::at(to_own2(1, start))];
        self.shuttle = Shuttle {
            p: self.hit_point(server),
            v: [0.0; 3],
        };
        self.hitter = server;
        self.flight = Flight::by(server);
        self.hits = 0;
        self.open = [false; 6];
        self.earned = [0.0; 6];
        self.log.clear();
        self.end = None;
        self.queue.clear();
        self.queue.push_back(Self::agent(server, Role::Serve));
        if self.rally.is_some() {
            self.rally = Some(Rally::default());
        }
        self.turn(StepInfo::default(), false)
    }

    fn act(&mut self, action: &[f32]) -> Turn {
        let Some(agent) = self.queue.pop_front() else {
            return Turn::default();
        };
        let (player, role) = Self::role_of(agent);
        self.open[agent] = true;
        self.earned[agent] = 0.0;
        self.on_margin_at_open[agent] = self.on_margin_steps[player];
        let info = match role {
            Role::Serve => self.hit(player, action),
            Role::Catch | Role::Reset => self.aim(player, action),
        };
        if self.queue.is_empty() {
            self.fly();
        }
        let ended_now = self.end.is_some();
        self.turn(info, ended_now)
    }
}

/// The six agents: `p0.catch`, `p0.serve`, `p0.reset`, `p1.catch`, ...
fn agent_specs(config: &Config) -> Vec<AgentSpec> {
    let (l, w) = (config.court.half_length, config.court.half_width);
    let far = 1e3;
    let v = config.hit.max_speed;
    let low = [-far, -far, -far, -v, -v, -v, -l, -w, 0.0, -w];
    let high = [far, far, far, v, v, v, 0.0, w, l, w];
    let observation_space = BoxSpace {
        low: low.iter().map(|&x| x as f32).collect(),
        high: high.iter().map(|&x| x as f32).collect(),
    };
    (0..2)
        .flat_map(|p| Role::ALL.map(|r| (p, r)))
        .map(|(p, role)| AgentSpec {
            name: format!("p{p}.{}", role.name()),
            observation_space: observation_space.clone(),
            action_space: BoxSpace {
                low: vec![-1.0; role.actions()],
                high: vec![1.0; role.actions()],
            },
        })
        .collect()
}
