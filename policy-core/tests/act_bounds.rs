//! `act` is finite and inside the bounds for every observation: finite (proptest), NaN,
//! infinite or huge, even for weights large enough to overflow the activations.

use policy_core::{ActionBounds, Activation, Policy};
use proptest::prelude::*;

use crate::support::{nav_policy, SplitMix64};

type Actor = Policy<2, 32, 1, 2>;

/// Any finite f32: both signs, normals, subnormals, zeros.
fn finite() -> impl Strategy<Value = f32> {
    use proptest::num::f32::{NEGATIVE, NORMAL, POSITIVE, SUBNORMAL, ZERO};
    POSITIVE | NEGATIVE | NORMAL | SUBNORMAL | ZERO
}

/// A policy with weights scaled by 10^exp (up to overflow) and arbitrary valid bounds.
fn policy(seed: u64, exp: i32, relu: bool, lo: f32, width: f32) -> Actor {
    let mut p: Actor = nav_policy(
        seed,
        if relu {
            Activation::Relu
        } else {
            Activation::Tanh
        },
    );
    let scale = 10f32.powi(exp);
    p.input.w.iter_mut().for_each(|w| *w *= scale);
    p.trunk.hidden[0].w.iter_mut().for_each(|w| *w *= scale);
    p.trunk.output.w.iter_mut().for_each(|w| *w *= scale);
    p.bounds = ActionBounds {
        low: [lo, -width].into(),
        high: [lo + width, width].into(),
    };
    p
}

fn assert_in_bounds(p: &Actor, obs: &[f32; 2]) {
    let a = p.act(obs);
    for (i, &v) in a.iter().enumerate() {
        assert!(v.is_finite(), "action {i} = {v} for {obs:?}");
        assert!(
            p.bounds.low[i] <= v && v <= p.bounds.high[i],
            "action {i} = {v} out of bounds"
        );
    }
    let u = p.act_unit(obs);
    assert!(u.iter().all(|v| v.is_finite() && v.abs() <= 1.0), "{u:?}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn finite_observations_give_finite_in_bounds_actions(
        obs in [finite(), finite()],
        seed in 0u64..1000,
        exp in -3i32..38,
        relu in any::<bool>(),
        lo in -1e6f32..1e6,
        width in 0f32..1e6,
    ) {
        let p = policy(seed, exp, relu, lo, width);
        prop_assume!(p.bounds.validate().is_ok());
        assert_in_bounds(&p, &obs);
    }
}

const SPECIAL: [f32; 12] = [
    f32::NAN,
    -f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::MAX,
    f32::MIN,
    1e30,
    -1e30,
    f32::MIN_POSITIVE,
    1e-45,
    0.0,
    -0.0,
];

#[test]
fn nan_inf_and_huge_observations_give_finite_in_bounds_actions() {
    for exp in [0, 10, 20, 38] {
        for relu in [false, true] {
            let p = policy(3, exp, relu, -0.25, 0.25);
            for &x in &SPECIAL {
                for &y in &SPECIAL {
                    assert_in_bounds(&p, &[x, y]);
                }
            }
        }
    }
}

/// The documented rule: a non-finite component is read as the mean (normalised 0).
#[test]
fn non_finite_component_acts_like_the_mean() {
    let p: Actor = nav_policy(4, Activation::Tanh);
    let m = p.normalizer.mean;
    let mut rng = SplitMix64(5);
    for _ in 0..100 {
        let y = 6.0 * rng.symmetric();
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(p.act(&[bad, y]), p.act(&[m[0], y]));
            assert_eq!(p.act(&[y, bad]), p.act(&[y, m[1]]));
        }
    }
}

/// Before anything is loaded a slot is safe: every action is 0.
#[test]
fn zero_policy_acts_zero() {
    let p = Actor::ZERO;
    for &x in &SPECIAL {
        assert_eq!(p.act(&[x, 1.0]), [0.0, 0.0]);
    }
}

/// Hand-built values that break the loader's rules must still never panic (the fields are
/// public); `f32::clamp` would panic on an inverted or NaN bound here.
#[test]
fn invalid_hand_built_parameters_do_not_panic() {
    let mut p: Actor = nav_policy(6, Activation::Tanh);
    p.normalizer.clip = -1.0;
    p.bounds = ActionBounds::symmetric(-0.25);
    let _ = p.act(&[1.0, 2.0]);
    p.normalizer.clip = f32::NAN;
    p.bounds.low[0] = f32::NAN;
    let _ = p.act(&[1.0, 2.0]);
    let tiny = Policy::<1, 0, 0, 0>::ZERO;
    assert_eq!(tiny.act(&[1.0]), []);
}
