//! The `oracle` reference controller: it knows the walls and follows the gaps.
//!
//! It plans on a visibility graph: the nodes are points a little way around every wall end
//! (where shortest paths bend), the edges are straight lines that keep clear of every wall, and
//! each node knows its shortest distance to the centre (Dijkstra, once per layout). Every tick
//! it heads for the visible node (or the centre itself) that minimises "distance there plus
//! distance from there". It exists to prove that the layouts are solvable and that the harness
//! scores a good policy as good; it is not a learning baseline.

use super::geometry::{nearest_wall_distance, Segment, Vec2};
use super::scenario::Scenario;
use super::straight::step_toward;
use crate::controller::Controller;

/// How far from a wall end the graph's nodes sit.
const NODE_OFFSET: f64 = 0.15;
/// Node-to-node edges keep at least this distance from every wall.
const EDGE_CLEARANCE: f64 = 0.05;
/// Nodes closer than this to the agent count as reached.
const REACHED: f64 = 1e-3;

/// The planner; build it once per layout.
#[derive(Clone, Debug)]
pub struct Oracle {
    walls: Vec<Segment>,
    nodes: Vec<Vec2>,
    /// Shortest distance from each node to the centre (infinite if unreachable).
    to_goal: Vec<f64>,
    max_step: f32,
}

impl Oracle {
    /// Builds the visibility graph for the scenario's walls.
    ///
    /// ```
    /// use firmware_sim::controller::Controller;
    /// use firmware_sim::nav::oracle::Oracle;
    /// use firmware_sim::nav::scenario::Scenario;
    /// let mut o = Oracle::new(&Scenario::builtin("nav-walls").unwrap());
    /// let mut a = [0.0; 2];
    /// // Below the closed middle of the outer south wall, the oracle heads sideways to a gap.
    /// o.act(&[0.0, -5.75], &mut a);
    /// assert!(a[0] > 0.0, "{a:?}");
    /// ```
    pub fn new(scenario: &Scenario) -> Oracle {
        let walls = scenario.segments();
        let h = scenario.arena_half_size;
        let nodes = candidate_nodes(&walls, h);
        let to_goal = distances_to_goal(&nodes, &walls);
        Oracle {
            walls,
            nodes,
            to_goal,
            max_step: scenario.max_step,
        }
    }

    /// The point the oracle heads for from `p`.
    ///
    /// ```
    /// use firmware_sim::nav::geometry::Vec2;
    /// use firmware_sim::nav::oracle::Oracle;
    /// use firmware_sim::nav::scenario::Scenario;
    /// let o = Oracle::new(&Scenario::builtin("nav-walls").unwrap());
    /// // Just above the inner ring's north gap, the centre is in sight.
    /// assert_eq!(o.waypoint(Vec2::new(0.0, 1.5)), Vec2::ZERO);
    /// // Beside the closed east side of the inner ring, it is not.
    /// assert_ne!(o.waypoint(Vec2::new(2.0, 0.0)), Vec2::ZERO);
    /// ```
    pub fn waypoint(&self, p: Vec2) -> Vec2 {
        let clearance = (0.5 * nearest_wall_distance(p, &self.walls)).min(EDGE_CLEARANCE);
        if visible(p, Vec2::ZERO, &self.walls, clearance) {
            return Vec2::ZERO;
        }
        let mut best = (f64::INFINITY, Vec2::ZERO);
        for (n, d) in self.nodes.iter().zip(&self.to_goal) {
            let here = (*n - p).norm();
            let cost = here + d;
            if here > REACHED && cost < best.0 && visible(p, *n, &self.walls, clearance) {
                best = (cost, *n);
            }
        }
        best.1
    }
}

impl Controller for Oracle {
    fn name(&self) -> String {
        "oracle".into()
    }
    fn observations(&self) -> usize {
        2
    }
    fn actions(&self) -> usize {
        2
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        if !obs.iter().all(|v| v.is_finite()) {
            action.fill(0.0);
            return;
        }
        let w = self.waypoint(Vec2::new(f64::from(obs[0]), f64::from(obs[1])));
        let step = step_toward([obs[0], obs[1]], [w.x as f32, w.y as f32], self.max_step);
        action.copy_from_slice(&step);
    }
}

fn visible(a: Vec2, b: Vec2, walls: &[Segment], clearance: f64) -> bool {
    let path = Segment::new(a, b);
    walls
        .iter()
        .all(|w| w.distance_to_segment(&path) > clearance)
}

/// Points at [`NODE_OFFSET`] around every wall end, in eight directions, that are inside the
/// arena and not too close to any wall.
fn candidate_nodes(walls: &[Segment], h: f64) -> Vec<Vec2> {
    let mut ends: Vec<Vec2> = Vec::new();
    for e in walls.iter().flat_map(|w| [w.a, w.b]) {
        if !ends.iter().any(|q| (*q - e).norm() < 1e-9) {
            ends.push(e);
        }
    }
    let mut nodes = Vec::new();
    for e in ends {
        for k in 0..8 {
            let angle = f64::from(k) * core::f64::consts::FRAC_PI_4;
            let n = e + Vec2::new(angle.cos(), angle.sin()).scale(NODE_OFFSET);
            let inside = n.x.abs() < h && n.y.abs() < h;
            if inside && nearest_wall_distance(n, walls) >= 0.6 * NODE_OFFSET {
                nodes.push(n);
            }
        }
    }
    nodes
}

/// Dijkstra from the centre over the visibility graph (dense, O(n²)).
fn distances_to_goal(nodes: &[Vec2], walls: &[Segment]) -> Vec<f64> {
    let n = nodes.len();
    let mut dist: Vec<f64> = nodes
        .iter()
        .map(|p| {
            if visible(*p, Vec2::ZERO, walls, EDGE_CLEARANCE) {
                p.norm()
            } else {
                f64::INFINITY
            }
        })
        .collect();
    let mut done = vec![false; n];
    for _ in 0..n {
        let next = (0..n)
            .filter(|&i| !done[i])
            .min_by(|&i, &j| dist[i].total_cmp(&dist[j]));
        let Some(i) = next else { break };
        if !dist[i].is_finite() {
            break;
        }
        done[i] = true;
        for j in 0..n {
            if done[j] {
                continue;
            }
            let via = dist[i] + (nodes[i] - nodes[j]).norm();
            if via < dist[j] && visible(nodes[i], nodes[j], walls, EDGE_CLEARANCE) {
                dist[j] = via;
            }
        }
    }
    dist
}
