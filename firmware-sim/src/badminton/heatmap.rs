//! What a trained player's critics think of the court (the paper's figures 15 and 16): the catch
//! critic's Q over the targets the catch agent can ask for, for one incoming ball, and the serve
//! critic's Q over the landing points its serve actions produce. Each map is computed from a
//! critic blob through policy-core, as a chip would evaluate it, and drawn as SVG with plotters.
//!
//! The states are fixed so that maps of different players and algorithms compare: the catch map
//! is taken at player 0's catch decision after the scripted player's first serve of a point
//! (seed 0) from the start positions; the serve map at player 0's serve from the start.

use plotters::prelude::*;
use policy_core::model::{Model, Scratch};

use super::court::{Court, Vec2};
use super::game::{Badminton, Role};
use super::player::target_of;
use super::reference::PlayerKind;
use super::shuttle::Fate;
use super::Config;
use crate::env::Plant;
use crate::Error;

/// The most grid steps per action dimension of the catch map (N² critic evaluations).
pub const MAX_GRID: usize = 200;
/// The most grid steps per action dimension of the serve map: N³ serves, each played to its
/// landing point (about 30 µs each), for a picture of some 600 squares. 64 steps are 262,144
/// serves, seconds of work and hundreds per square; 200 were 8,000,000, minutes.
pub const MAX_SERVE_GRID: usize = 64;

/// A critic's values at points of the court (own frame of player 0 = world frame).
#[derive(Clone, Debug, PartialEq)]
pub struct Map {
    /// Which agent's critic.
    pub role: Role,
    /// The observation the critic was asked about.
    pub observation: Vec<f32>,
    /// (x, y, Q) per grid action that has a point: every catch target; every serve that lands
    /// (in or out).
    pub points: Vec<(f64, f64, f32)>,
    /// Serve actions whose ball went into the net (no landing point), with their mean Q.
    pub net: (usize, f32),
    /// Where the incoming ball would land (catch map), if it lands.
    pub ball: Option<Vec2>,
}

/// The catch critic's Q over an `n` × `n` grid of catch actions (targets on the own half).
///
/// ```
/// use firmware_sim::badminton::heatmap::catch_map;
/// use firmware_sim::badminton::Config;
/// use policy_core::{ActionBounds, Critic, Normalizer};
/// let mut q = Critic::<10, 16, 1, 2>::ZERO;
/// q.normalizer = Normalizer::identity(1e3);
/// let blob = q.to_blob("zero").unwrap();
/// let map = catch_map(&Config::builtin(), &blob, 5).unwrap();
/// assert_eq!(map.points.len(), 25);
/// assert!(map.points.iter().all(|&(x, _, q)| x <= 0.0 && q == 0.0));
/// ```
pub fn catch_map(config: &Config, critic: &[u8], n: usize) -> Result<Map, Error> {
    let critic = boot_critic(critic, Role::Catch)?;
    check_grid(n, MAX_GRID, "")?;
    let mut game = Badminton::new(config)?;
    let mut server = PlayerKind::Scripted.build(config, 0, 1);
    game.set_server(1);
    let mut turn = game.reset(0);
    let mut action = [0.0f32; 3];
    let observation = loop {
        let Some(decision) = turn.decide else {
            return Err(Error::Config {
                field: "heat map",
                message: "the scripted serve ended the point before player 0 could catch".into(),
            });
        };
        let (player, role) = Badminton::role_of(decision.agent);
        if (player, role) == (0, Role::Catch) {
            break decision.observation;
        }
        let a = &mut action[..role.actions()];
        if player == 1 {
            server.act(role, &decision.observation, a);
        } else {
            a.fill(0.0);
        }
        turn = game.act(a);
    };
    let ball = game.hits().last().and_then(|h| landing(h.fate));
    let court = Court::of(&config.court);
    let mut scratch = Box::new(Scratch::<{ crate::controller::SCRATCH_WIDTH }>::new());
    let mut points = Vec::with_capacity(n * n);
    for i in 0..n {
        for j in 0..n {
            let a = [grid(i, n), grid(j, n)];
            let q = critic.q(&observation, &a, &mut scratch)?;
            let [x, y] = target_of(&a, &court);
            points.push((x, y, q));
        }
    }
    Ok(Map {
        role: Role::Catch,
        observation,
        points,
        net: (0, f32::NAN),
        ball,
    })
}

/// The serve critic's Q over an `n` × `n` × `n` grid of serve actions, each placed where its
/// ball lands (the plant plays the serve to its dead ball); net balls are counted apart.
pub fn serve_map(config: &Config, critic: &[u8], n: usize) -> Result<Map, Error> {
    let critic = boot_critic(critic, Role::Serve)?;
    check_grid(
        n,
        MAX_SERVE_GRID,
        " for a serve map, whose N³ serves are each played to their landing (the picture shows \
         some 600 squares: more steps add work, not detail)",
    )?;
    let mut game = Badminton::new(config)?;
    game.set_server(0);
    let turn = game.reset(0);
    let Some(decision) = turn.decide else {
        return Err(Error::Config {
            field: "heat map",
            message: "a point started without a serve".into(),
        });
    };
    let observation = decision.observation;
    let mut scratch = Box::new(Scratch::<{ crate::controller::SCRATCH_WIDTH }>::new());
    let (mut points, mut net, mut net_q) = (Vec::new(), 0, 0.0f64);
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                let a = [grid(i, n), grid(j, n), grid(k, n)];
                let q = critic.q(&observation, &a, &mut scratch)?;
                let mut serve = game.clone();
                serve.act(&a);
                match serve.hits().first().and_then(|h| landing(h.fate)) {
                    Some([x, y]) => points.push((x, y, q)),
                    None => {
                        net += 1;
                        net_q += f64::from(q);
                    }
                }
            }
        }
    }
    let net_mean = if net == 0 {
        f32::NAN
    } else {
        (net_q / net as f64) as f32
    };
    Ok(Map {
        role: Role::Serve,
        observation,
        points,
        net: (net, net_mean),
        ball: None,
    })
}

/// The map as an SVG picture: the court's outline and net, the points binned into squares of a
/// fifteenth of half the court's length, each coloured by the mean Q of its points on the
/// viridis scale from the map's smallest Q (dark) to its largest (yellow); the catch map's
/// incoming ball as a red cross.
pub fn svg(map: &Map, config: &Config, title: &str) -> Result<String, Error> {
    let court = Court::of(&config.court);
    let (l, w) = (court.half_length, court.half_width);
    let finite = map.points.iter().map(|p| p.2).filter(|q| q.is_finite());
    let (lo, hi) = finite.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), q| {
        (a.min(q), b.max(q))
    });
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (720, 360)).into_drawing_area();
        draw(&root, map, title, (l, w), (lo, hi)).map_err(|e| Error::Config {
            field: "heat map",
            message: format!("drawing failed: {e}"),
        })?;
    }
    Ok(text)
}

type Drawn = Result<(), DrawingAreaErrorKind<std::io::Error>>;

fn draw(
    root: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    map: &Map,
    title: &str,
    (l, w): (f64, f64),
    (lo, hi): (f32, f32),
) -> Drawn {
    root.fill(&WHITE)?;
    let caption = match map.role {
        Role::Serve => format!(
            "{title}: Q {lo:.3} (dark) to {hi:.3} (yellow); {} serves into the net",
            map.net.0
        ),
        _ => format!("{title}: Q {lo:.3} (dark) to {hi:.3} (yellow)"),
    };
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 14))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(-l - 1.0..l + 1.0, -w - 1.0..w + 1.0)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("x (m), player 0 plays from x < 0")
        .y_desc("y (m)")
        .draw()?;
    let span = (hi - lo).max(f32::MIN_POSITIVE);
    let side = l / CELLS_PER_HALF_LENGTH;
    let cell = side / 2.0;
    let drawn = cells(&map.points, side, (l + 1.0, w + 1.0));
    chart.draw_series(drawn.into_iter().map(|(x, y, q)| {
        let colour = if q.is_finite() {
            ViridisRGB::get_color(f64::from((q - lo) / span))
        } else {
            RGBColor(200, 200, 200)
        };
        Rectangle::new(
            [(x - cell, y - cell), (x + cell, y + cell)],
            colour.filled(),
        )
    }))?;
    let outline = [(-l, -w), (l, -w), (l, w), (-l, w), (-l, -w)];
    chart.draw_series(std::iter::once(PathElement::new(outline, BLACK)))?;
    chart.draw_series(std::iter::once(PathElement::new(
        [(0.0, -w), (0.0, w)],
        BLACK.stroke_width(3),
    )))?;
    if let Some([x, y]) = map.ball {
        chart.draw_series(std::iter::once(Cross::new((x, y), 6, RED.stroke_width(2))))?;
    }
    root.present()
}

/// Drawn cells along half the court's length: the squares of the picture.
const CELLS_PER_HALF_LENGTH: f64 = 15.0;

/// The points as the picture shows them: binned into squares of `side` (each the mean of its
/// finite Qs, NaN if it has none), those beyond the drawn area `(x, y)` left out. The picture's
/// size is then bounded by the court's area, whatever the grid (a 200-step serve grid made an
/// SVG of 400 MB when every point was a square of its own).
fn cells(points: &[(f64, f64, f32)], side: f64, (xm, ym): (f64, f64)) -> Vec<(f64, f64, f32)> {
    let mut bins = std::collections::BTreeMap::<(i64, i64), (f64, u32)>::new();
    for &(x, y, q) in points {
        if x.abs() > xm || y.abs() > ym {
            continue;
        }
        let key = ((x / side).floor() as i64, (y / side).floor() as i64);
        let bin = bins.entry(key).or_insert((0.0, 0));
        if q.is_finite() {
            *bin = (bin.0 + f64::from(q), bin.1 + 1);
        }
    }
    let centre = |i: i64| (i as f64 + 0.5) * side;
    bins.into_iter()
        .map(|((i, j), (sum, n))| {
            let q = if n == 0 {
                f32::NAN
            } else {
                (sum / f64::from(n)) as f32
            };
            (centre(i), centre(j), q)
        })
        .collect()
}

/// The landing point of a flight that lands (in or out); none for a net ball.
fn landing(fate: Fate) -> Option<Vec2> {
    match fate {
        Fate::In(p) | Fate::Out(p) => Some(p),
        Fate::Net => None,
    }
}

/// Grid step `i` of `n` across `[-1, 1]`, both ends included.
fn grid(i: usize, n: usize) -> f32 {
    if n <= 1 {
        0.0
    } else {
        -1.0 + 2.0 * i as f32 / (n - 1) as f32
    }
}

fn check_grid(n: usize, max: usize, why: &str) -> Result<(), Error> {
    if (1..=max).contains(&n) {
        Ok(())
    } else {
        Err(Error::Config {
            field: "--grid",
            message: format!("expected 1..={max} steps per action{why}, found {n}"),
        })
    }
}

/// A critic blob for `role`: 10 observations and the role's actions.
fn boot_critic(bytes: &[u8], role: Role) -> Result<Model<'_>, Error> {
    let model = Model::from_blob(bytes)?;
    if model.header().kind != policy_core::ModelKind::Critic {
        return Err(policy_core::Error::WrongKind {
            expected: policy_core::ModelKind::Critic,
            found: model.header().kind,
        }
        .into());
    }
    model.expect_sizes(super::game::OBSERVATIONS, role.actions())?;
    Ok(model)
}
