//! What drives the actuator: a policy booted from a blob, the safe state, or a reference
//! controller (`straight`, `oracle`) used to check the harness and its metrics.

use policy_core::blob::{self, Header};
use policy_core::{ModelKind, Policy, Shape};

use crate::oracle::Oracle;
use crate::scenario::Scenario;
use crate::Error;

/// A controller in the firmware loop: observation in, action out.
///
/// The trainer may implement it for its own networks to run them through the same loop.
pub trait Controller {
    /// A short name for reports.
    fn name(&self) -> String;
    /// Observation size it reads.
    fn observations(&self) -> usize;
    /// Action size it writes.
    fn actions(&self) -> usize;
    /// Called before every episode (controllers with memory forget it here).
    fn reset(&mut self) {}
    /// Writes the action for `obs` into `action`. Anything may come out (NaN included): the
    /// actuator model sanitises it before it reaches the plant.
    fn act(&mut self, obs: &[f32], action: &mut [f32]);
}

/// The safe state a loop enters when the blob fails to load: every action is 0.
#[derive(Clone, Copy, Debug)]
pub struct SafeState {
    /// Observation size of the plant.
    pub observations: usize,
    /// Action size of the plant.
    pub actions: usize,
}

impl Controller for SafeState {
    fn name(&self) -> String {
        "safe-state".into()
    }
    fn observations(&self) -> usize {
        self.observations
    }
    fn actions(&self) -> usize {
        self.actions
    }
    fn act(&mut self, _obs: &[f32], action: &mut [f32]) {
        action.fill(0.0);
    }
}

/// Heads straight for the centre at full speed: the naive policy a wall catches.
#[derive(Clone, Copy, Debug)]
pub struct Straight {
    /// Largest step per axis.
    pub max_step: f32,
}

impl Controller for Straight {
    fn name(&self) -> String {
        "straight".into()
    }
    fn observations(&self) -> usize {
        2
    }
    fn actions(&self) -> usize {
        2
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        let to = step_toward([obs[0], obs[1]], [0.0, 0.0], self.max_step);
        action.copy_from_slice(&to);
    }
}

/// The step from `from` toward `to`: the full step along the direction (largest component
/// `max_step`, so the direction is kept exactly inside the box), or exactly the remaining
/// offset when it is shorter. A non-finite input gives no motion.
///
/// ```
/// use firmware_sim::controller::step_toward;
/// assert_eq!(step_toward([4.0, 2.0], [0.0, 0.0], 0.25), [-0.25, -0.125]);
/// assert_eq!(step_toward([0.1, 0.0], [0.0, 0.0], 0.25), [-0.1, 0.0]);
/// assert_eq!(step_toward([f32::NAN, 0.0], [0.0, 0.0], 0.25), [0.0, 0.0]);
/// ```
pub fn step_toward(from: [f32; 2], to: [f32; 2], max_step: f32) -> [f32; 2] {
    let d = [to[0] - from[0], to[1] - from[1]];
    // `f32::max` ignores NaN, so finiteness is checked per component.
    if !d.iter().all(|v| v.is_finite()) {
        return [0.0, 0.0];
    }
    let big = d[0].abs().max(d[1].abs());
    if big <= max_step {
        return d;
    }
    let k = max_step / big;
    [d[0] * k, d[1] * k]
}

/// A reference controller by name: `straight` or `oracle`.
///
/// ```
/// use firmware_sim::controller::reference;
/// use firmware_sim::scenario::Scenario;
/// let s = Scenario::builtin("nav-walls").unwrap();
/// let mut c = reference("straight", &s).unwrap();
/// let mut a = [0.0; 2];
/// c.act(&[5.75, 0.0], &mut a);
/// assert_eq!(a, [-0.25, 0.0]);
/// assert!(reference("wander", &s).is_err());
/// ```
pub fn reference(name: &str, scenario: &Scenario) -> Result<Box<dyn Controller>, Error> {
    match name {
        "straight" => Ok(Box::new(Straight {
            max_step: scenario.max_step,
        })),
        "oracle" => Ok(Box::new(Oracle::new(scenario))),
        _ => Err(Error::Config {
            field: "controller",
            message: format!("expected straight or oracle, found {name:?}"),
        }),
    }
}

/// A policy of one compiled shape, behind a uniform interface.
trait DynPolicy {
    fn act(&self, obs: &[f32], action: &mut [f32]);
}

impl<const S: usize, const H: usize, const L: usize, const A: usize> DynPolicy
    for Policy<S, H, L, A>
{
    #[inline]
    fn act(&self, obs: &[f32], action: &mut [f32]) {
        let mut o = [0.0f32; S];
        o.iter_mut().zip(obs).for_each(|(d, s)| *d = *s);
        let a = Policy::act(self, &o);
        action.iter_mut().zip(&a).for_each(|(d, s)| *d = *s);
    }
}

fn boot<const S: usize, const H: usize, const L: usize, const A: usize>(
    bytes: &[u8],
) -> Result<Box<dyn DynPolicy>, Error> {
    // Loaded in place into a heap slot, as the chip loads into a `static`: a 6x64 policy is
    // ~80 KB and is never returned by value.
    let mut slot = Box::new(Policy::<S, H, L, A>::ZERO);
    slot.load_into(bytes)?;
    Ok(slot)
}

/// Expands the list of compiled shapes into the dispatch `match` and the [`SUPPORTED`] table.
macro_rules! compiled_shapes {
    ($( ($s:literal, $a:literal, $h:literal, $d:literal) ),* $(,)?) => {
        /// Every shape this build can run: (observations, actions, width, depth).
        pub const SUPPORTED: &[Shape] = &[
            $( Shape { observations: $s, actions: $a, width: $h, depth: $d }, )*
        ];

        fn dispatch(shape: Shape, bytes: &[u8]) -> Option<Result<Box<dyn DynPolicy>, Error>> {
            match (shape.observations, shape.actions, shape.width, shape.depth) {
                $( ($s, $a, $h, $d) => Some(boot::<$s, $h, { $d - 1 }, $a>(bytes)), )*
                _ => None,
            }
        }
    };
}

// The navigation plant (2 observations, 2 actions) at every network size of the paper:
// widths 32, 48, 64 and 2 to 6 hidden layers.
compiled_shapes!(
    (2, 2, 32, 2),
    (2, 2, 32, 3),
    (2, 2, 32, 4),
    (2, 2, 32, 5),
    (2, 2, 32, 6),
    (2, 2, 48, 2),
    (2, 2, 48, 3),
    (2, 2, 48, 4),
    (2, 2, 48, 5),
    (2, 2, 48, 6),
    (2, 2, 64, 2),
    (2, 2, 64, 3),
    (2, 2, 64, 4),
    (2, 2, 64, 5),
    (2, 2, 64, 6),
);

/// The compiled shapes as one line.
///
/// ```
/// let list = firmware_sim::controller::supported_list();
/// assert!(list.starts_with("2 obs/2 act depth {2,3,4,5,6} x width 32;"), "{list}");
/// ```
pub fn supported_list() -> String {
    let mut groups: Vec<(u16, u16, u16, Vec<u8>)> = Vec::new();
    for s in SUPPORTED {
        match groups.last_mut() {
            Some(g) if (g.0, g.1, g.2) == (s.observations, s.actions, s.width) => g.3.push(s.depth),
            _ => groups.push((s.observations, s.actions, s.width, vec![s.depth])),
        }
    }
    let parts: Vec<String> = groups
        .iter()
        .map(|(o, a, w, ds)| {
            let ds: Vec<String> = ds.iter().map(u8::to_string).collect();
            format!("{o} obs/{a} act depth {{{}}} x width {w}", ds.join(","))
        })
        .collect();
    parts.join("; ")
}

/// A policy booted from blob bytes, of whichever compiled shape its header names.
pub struct BlobPolicy {
    policy: Box<dyn DynPolicy>,
    header: Header,
}

impl core::fmt::Debug for BlobPolicy {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("BlobPolicy")
            .field("header", &self.header)
            .finish_non_exhaustive()
    }
}

impl BlobPolicy {
    /// Boots from blob bytes: checks the header with `policy_core::blob::verify`, picks the
    /// compiled type for its shape, and loads into it.
    ///
    /// ```
    /// use firmware_sim::controller::{BlobPolicy, Controller};
    /// use policy_core::{ActionBounds, Normalizer, Policy};
    /// let mut p = Policy::<2, 48, 3, 2>::ZERO;
    /// p.normalizer = Normalizer::identity(5.0);
    /// p.bounds = ActionBounds::symmetric(0.25);
    /// p.trunk.output.b[0] = 10.0; // tanh saturates: always +0.25 on x
    /// let blob = p.to_blob("demo").unwrap();
    /// let mut c = BlobPolicy::boot(&blob).unwrap();
    /// let mut a = [0.0; 2];
    /// c.act(&[1.0, 2.0], &mut a);
    /// assert_eq!(a, [0.25, 0.0]);
    /// assert!(BlobPolicy::boot(&blob[1..]).is_err());
    /// ```
    pub fn boot(bytes: &[u8]) -> Result<BlobPolicy, Error> {
        let header = blob::verify(bytes)?.header;
        if header.kind != ModelKind::Actor {
            return Err(policy_core::Error::WrongKind {
                expected: ModelKind::Actor,
                found: header.kind,
            }
            .into());
        }
        let policy = dispatch(header.shape, bytes).ok_or_else(|| Error::UnsupportedShape {
            found: header.shape,
            supported: supported_list(),
        })??;
        Ok(BlobPolicy { policy, header })
    }

    /// The blob's header (shape, activation, label).
    pub fn header(&self) -> &Header {
        &self.header
    }
}

impl Controller for BlobPolicy {
    fn name(&self) -> String {
        let s = self.header.shape;
        format!(
            "blob {:?} {}x{} {}",
            self.header.label.as_str(),
            s.depth,
            s.width,
            self.header.activation
        )
    }
    fn observations(&self) -> usize {
        self.header.shape.observations as usize
    }
    fn actions(&self) -> usize {
        self.header.shape.actions as usize
    }
    #[inline]
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        self.policy.act(obs, action);
    }
}
