//! The device-side compare step never returns an action with lower Q than the actor's own.

use policy_core::compare::{refine, standard_normal};
use policy_core::{Activation, Critic, Policy};
use proptest::prelude::*;

use crate::support::{nav_critic, nav_policy, SplitMix64};

type Actor = Policy<2, 32, 1, 2>;
type Q = Critic<2, 32, 1, 2>;

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

/// The runtime compare step (actor and critic straight from their blob bytes) returns what the
/// compiled one returns, bit for bit: same proposals, same comparisons, same scaled action.
#[test]
fn refine_model_equals_the_compiled_refine() {
    use crate::support::blob_of;
    use policy_core::compare::refine_model;
    use policy_core::model::{Model, Scratch};
    let mut scratch = Scratch::<64>::new();
    for seed in 0..40u64 {
        let (policy, critic) = models(seed, seed % 2 == 0);
        let (pb, cb) = (blob_of(&policy, "actor"), blob_of(&critic, "critic"));
        let (actor_m, critic_m) = (
            Model::from_blob(&pb).expect("actor"),
            Model::from_blob(&cb).expect("critic"),
        );
        let mut obs_rng = SplitMix64(seed);
        for t in [0, 1, 4, 16] {
            let obs = [8.0 * obs_rng.symmetric(), 8.0 * obs_rng.symmetric()];
            let want = refine(&policy, &critic, &obs, &mut SplitMix64(seed + 99), t, 0.2);
            let got = refine_model::<2, 64, _>(
                &actor_m,
                &critic_m,
                &obs,
                &mut scratch,
                &mut SplitMix64(seed + 99),
                t,
                0.2,
            )
            .expect("refine_model");
            assert_eq!(got.winner, want.winner, "seed {seed} t {t}");
            assert_eq!(got.unit.map(f32::to_bits), want.unit.map(f32::to_bits));
            assert_eq!(got.action.map(f32::to_bits), want.action.map(f32::to_bits));
            assert_eq!(got.advantage.to_bits(), want.advantage.to_bits());
        }
    }
    // Kinds and sizes that do not fit are errors, not panics.
    let (policy, critic) = models(1, true);
    let (pb, cb) = (blob_of(&policy, "actor"), blob_of(&critic, "critic"));
    let (a, c) = (
        Model::from_blob(&pb).expect("a"),
        Model::from_blob(&cb).expect("c"),
    );
    let mut rng = SplitMix64(3);
    assert!(refine_model::<2, 64, _>(&c, &a, &[0.0; 2], &mut scratch, &mut rng, 4, 0.2).is_err());
    assert!(refine_model::<3, 64, _>(&a, &c, &[0.0; 2], &mut scratch, &mut rng, 4, 0.2).is_err());
    let mut narrow = Scratch::<8>::new();
    assert!(refine_model::<2, 8, _>(&a, &c, &[0.0; 2], &mut narrow, &mut rng, 4, 0.2).is_err());
}
