//! The device-side compare step never returns an action with lower Q than the actor's own.

use policy_core::compare::{refine, standard_normal};
use policy_core::{Activation, Critic, Policy};
use proptest::prelude::*;

use crate::support::{nav_critic, nav_policy, SplitMix64};

type Actor = Policy<2, 32, 1, 2>;
type Q = Critic<2, 2, 32, 1>;

fn models(seed: u64, relu: bool) -> (Actor, Q) {
    let act = if relu {
        Activation::Relu
    } else {
        Activation::Tanh
    };
    (nav_policy(seed, act), nav_critic(seed ^ 0xC, act))
}

fn sigma() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => 0.001f32..3.0,
        1 => Just(0.0f32),
        1 => Just(-1.0f32),
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(1e30f32),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn refine_is_never_worse_than_the_actor(
        seed in 0u64..500,
        relu in any::<bool>(),
        obs in [-10f32..10.0, -10f32..10.0],
        t in 0usize..24,
        sigma in sigma(),
        rng_seed in any::<u64>(),
    ) {
        let (p, c) = models(seed, relu);
        let r = refine(&p, &c, &obs, &mut SplitMix64(rng_seed), t, sigma);
        let a0 = p.act_unit(&obs);
        let (q0, q) = (c.q(&obs, &a0), c.q(&obs, &r.unit));
        prop_assert!(q >= q0, "q {q} < q0 {q0}");
        prop_assert!(r.winner <= t);
        prop_assert_eq!(r.action, p.bounds.scale(&r.unit));
        prop_assert!(r.unit.iter().all(|u| u.abs() <= 1.0));
        if r.winner == 0 {
            prop_assert_eq!(r.unit, a0);
            prop_assert_eq!(r.advantage, 0.0);
        } else {
            prop_assert!(r.advantage > 0.0);
            prop_assert_eq!(r.advantage, q - q0);
        }
        if t == 0 || !(sigma.is_finite() && sigma > 0.0) {
            prop_assert_eq!(r.winner, 0);
        }
    }
}

/// The test above could pass with a `refine` that never explores; this one could not.
#[test]
fn refine_finds_better_actions_and_is_reproducible() {
    let (p, c) = models(1, false);
    let mut rng = SplitMix64(0);
    let mut wins = 0;
    for _ in 0..100 {
        let obs = [6.0 * rng.symmetric(), 6.0 * rng.symmetric()];
        let seed = rng.next();
        let r = refine(&p, &c, &obs, &mut SplitMix64(seed), 16, 0.3);
        assert_eq!(r, refine(&p, &c, &obs, &mut SplitMix64(seed), 16, 0.3));
        wins += usize::from(r.winner > 0);
    }
    assert!(
        wins > 50,
        "only {wins} of 100 refinements improved on the actor"
    );
}

#[test]
fn standard_normal_has_unit_moments() {
    let mut rng = SplitMix64(77);
    let n = 100_000;
    let xs: Vec<f64> = (0..n)
        .map(|_| f64::from(standard_normal(&mut rng)))
        .collect();
    let mean = xs.iter().sum::<f64>() / n as f64;
    let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
    assert!(mean.abs() < 0.01, "{mean}");
    assert!((var - 1.0).abs() < 0.02, "{var}");
    assert!(xs.iter().all(|x| x.is_finite()));
}
