//! Golden vectors: committed blobs, inputs and expected outputs, asserted bit for bit.
//!
//! The blobs in `tests/golden/` are built from fixed seeds by [`crate::support`]; `vectors.txt`
//! lists inputs and outputs as f32 bit patterns (hex), so a trainer or another implementation
//! can check it computes exactly what the chip computes. Run with `UPDATE_GOLDEN=1` to
//! regenerate them after a deliberate format or arithmetic change (and say so in the commit).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use policy_core::compare::refine;
use policy_core::{Activation, Critic, Policy};

use crate::support::{blob_of, nav_critic, nav_policy, SplitMix64};

type Actor2x32 = Policy<2, 32, 1, 2>;
type Actor4x48 = Policy<2, 48, 3, 2>;
type Critic2x32 = Critic<2, 32, 1, 2>;

const ACTOR_2X32: &str = "actor_2x32.postcard";
const ACTOR_4X48: &str = "actor_4x48.postcard";
const CRITIC_2X32: &str = "critic_2x32.postcard";
const VECTORS: &str = "vectors.txt";

fn actor_2x32() -> Actor2x32 {
    nav_policy(0x2032, Activation::Tanh)
}
fn actor_4x48() -> Actor4x48 {
    nav_policy(0x4048, Activation::Tanh)
}
fn critic_2x32() -> Critic2x32 {
    nav_critic(0xC2032, Activation::Relu)
}

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// The files as the generator makes them today.
fn generated() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        (ACTOR_2X32, blob_of(&actor_2x32(), "golden actor 2x32 tanh")),
        (ACTOR_4X48, blob_of(&actor_4x48(), "golden actor 4x48 tanh")),
        (
            CRITIC_2X32,
            blob_of(&critic_2x32(), "golden critic 2x32 relu"),
        ),
        (VECTORS, vectors_text().into_bytes()),
    ]
}

/// Observations: the arena's corners and centre, sensor faults, extremes, then random points.
fn observations() -> Vec<[f32; 2]> {
    let mut obs = vec![
        [0.0, 0.0],
        [-0.0, 0.0],
        [6.0, 6.0],
        [-6.0, -6.0],
        [6.0, -6.0],
        [0.25, -0.25],
        [5.75, 0.0],
        [f32::NAN, 1.0],
        [1.0, f32::NAN],
        [f32::INFINITY, f32::NEG_INFINITY],
        [f32::NEG_INFINITY, 2.0],
        [1e30, -1e30],
        [f32::MAX, f32::MIN],
        [1e-40, -3.0],
    ];
    let mut rng = SplitMix64(0x0B5);
    obs.extend((0..24).map(|_| [6.5 * rng.symmetric(), 6.5 * rng.symmetric()]));
    obs
}

/// Proposal counts cycle through 1, 2, 4 and 16 so some vectors keep the actor's action.
fn refine_t(i: usize) -> usize {
    [1, 2, 4, 16][i % 4]
}

fn hex(values: &[f32]) -> String {
    values
        .iter()
        .map(|v| format!("{:08x}", v.to_bits()))
        .collect::<Vec<_>>()
        .join(" ")
}

fn decimal(values: &[f32]) -> String {
    values
        .iter()
        .map(|v| format!("{v:e}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// `<op> <inputs> -> <outputs>  # decimal outputs`; see the file's own header.
fn vectors_text() -> String {
    let (a2, a4, c2) = (actor_2x32(), actor_4x48(), critic_2x32());
    let mut t = String::from(HEADER);
    for o in observations() {
        let a = a2.act(&o);
        writeln!(t, "act2x32 {} -> {}  # {}", hex(&o), hex(&a), decimal(&a)).expect("string");
    }
    for o in observations() {
        let a = a4.act(&o);
        writeln!(t, "act4x48 {} -> {}  # {}", hex(&o), hex(&a), decimal(&a)).expect("string");
    }
    let mut rng = SplitMix64(0xA0);
    for o in observations() {
        let u = [rng.symmetric(), rng.symmetric()];
        let q = [c2.q(&o, &u)];
        writeln!(
            t,
            "q2x32 {} {} -> {}  # {}",
            hex(&o),
            hex(&u),
            hex(&q),
            decimal(&q)
        )
        .expect("string");
    }
    for (i, o) in observations().iter().enumerate() {
        let (seed, t_count, sigma) = (i as u64, refine_t(i), 0.3f32);
        let r = refine(&a2, &c2, o, &mut SplitMix64(seed), t_count, sigma);
        let out = [r.unit[0], r.unit[1], r.action[0], r.action[1], r.advantage];
        writeln!(
            t,
            "refine2x32 {} {} {} {} -> {} {}  # winner {} advantage {:e}",
            seed,
            t_count,
            hex(&[sigma]),
            hex(o),
            hex(&out),
            r.winner,
            r.winner,
            r.advantage
        )
        .expect("string");
    }
    t
}

const HEADER: &str = "\
# policy-core golden vectors. Every number is an f32 bit pattern in hex unless noted.
# Models: actor_2x32.postcard (Policy<2,32,1,2>), actor_4x48.postcard (Policy<2,48,3,2>),
# critic_2x32.postcard (Critic<2,32,1,2>). Lines:
#   act2x32 | act4x48   obs0 obs1 -> action0 action1                 (Policy::act)
#   q2x32    obs0 obs1 unit0 unit1 -> q                            (Critic::q)
#   refine2x32 seed(dec) t(dec) sigma obs0 obs1 -> unit0 unit1 action0 action1 advantage winner(dec)
#     (compare::refine with the 2x32 actor and critic; RNG = SplitMix64 seeded with `seed`,
#      next_u32 = high 32 bits of next_u64)
# Text after '#' is a decimal rendering for people; the test ignores it.
";

fn parse_hex(token: &str) -> f32 {
    f32::from_bits(u32::from_str_radix(token, 16).expect("hex f32 bits"))
}

/// Recomputes one line's outputs from its inputs with the committed blobs.
fn recompute(line: &str, a2: &Actor2x32, a4: &Actor4x48, c2: &Critic2x32) -> Vec<String> {
    let (lhs, rhs) = line.split_once("->").expect("a vector line has '->'");
    let mut input = lhs.split_whitespace();
    let op = input.next().expect("op");
    let rest: Vec<&str> = input.collect();
    let f = |i: usize| parse_hex(rest[i]);
    let outputs: Vec<f32> = match op {
        "act2x32" => a2.act(&[f(0), f(1)]).to_vec(),
        "act4x48" => a4.act(&[f(0), f(1)]).to_vec(),
        "q2x32" => vec![c2.q(&[f(0), f(1)], &[f(2), f(3)])],
        "refine2x32" => {
            let seed: u64 = rest[0].parse().expect("seed");
            let t: usize = rest[1].parse().expect("t");
            let r = refine(a2, c2, &[f(3), f(4)], &mut SplitMix64(seed), t, f(2));
            let mut tokens: Vec<String> =
                [r.unit[0], r.unit[1], r.action[0], r.action[1], r.advantage]
                    .iter()
                    .map(|v| format!("{:08x}", v.to_bits()))
                    .collect();
            tokens.push(r.winner.to_string());
            assert_eq!(tokens.len(), rhs.split_whitespace().count(), "{line}");
            return tokens;
        }
        other => panic!("unknown op {other:?} in {VECTORS}"),
    };
    outputs
        .iter()
        .map(|v| format!("{:08x}", v.to_bits()))
        .collect()
}

#[test]
fn golden_files_match_generator_or_update() {
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::create_dir_all(dir()).expect("create tests/golden");
        for (name, bytes) in generated() {
            // Atomic: a reader never sees a half-written golden file.
            let tmp = dir().join(format!("{name}.tmp"));
            std::fs::write(&tmp, &bytes).expect("write golden tmp");
            std::fs::rename(&tmp, dir().join(name)).expect("rename golden");
        }
    }
    for (name, bytes) in generated() {
        let committed = std::fs::read(dir().join(name)).expect("golden file (UPDATE_GOLDEN=1)");
        assert!(
            committed == bytes,
            "{name} differs from the generator; see golden.rs"
        );
    }
}

#[test]
fn committed_blobs_reproduce_expected_outputs_bit_exactly() {
    let read = |name: &str| std::fs::read(dir().join(name)).expect("golden blob");
    let a2 = Actor2x32::from_blob(&read(ACTOR_2X32)).expect("load actor 2x32");
    let a4 = Actor4x48::from_blob(&read(ACTOR_4X48)).expect("load actor 4x48");
    let c2 = Critic2x32::from_blob(&read(CRITIC_2X32)).expect("load critic 2x32");
    assert_eq!(a2, actor_2x32());
    let text = std::fs::read_to_string(dir().join(VECTORS)).expect("vectors.txt");
    let mut checked = 0;
    for line in text
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
    {
        if line.is_empty() {
            continue;
        }
        let expected: Vec<&str> = line
            .split_once("->")
            .expect("->")
            .1
            .split_whitespace()
            .collect();
        assert_eq!(
            recompute(line, &a2, &a4, &c2),
            expected,
            "vector line: {line}"
        );
        checked += 1;
    }
    assert_eq!(checked, 4 * observations().len());
}

/// A guard on the fixtures themselves: the vectors must exercise the interesting regimes, not
/// a saturated or constant network.
#[test]
fn golden_outputs_are_not_degenerate() {
    let a2 = actor_2x32();
    let acts: Vec<[f32; 2]> = observations().iter().map(|o| a2.act(o)).collect();
    let interior = acts.iter().flatten().filter(|a| a.abs() < 0.24).count();
    assert!(
        interior > acts.len(),
        "most action components should be unsaturated"
    );
    let distinct = acts
        .iter()
        .map(|a| a[0].to_bits())
        .collect::<std::collections::HashSet<_>>();
    assert!(distinct.len() > 20);
    let c2 = critic_2x32();
    let wins = observations()
        .iter()
        .enumerate()
        .filter(|(i, o)| {
            refine(&a2, &c2, o, &mut SplitMix64(*i as u64), refine_t(*i), 0.3).winner > 0
        })
        .count();
    assert!(
        wins > 5 && wins < observations().len(),
        "refine should sometimes keep a0: {wins}"
    );
}
