use firmware_sim::boot::{boot, PlantSizes};
use firmware_sim::controller::{BlobPolicy, Controller};
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use firmware_sim::Error;
use policy_core::model::{Model, Scratch};
use policy_core::{Activation, ModelKind, Policy, Shape};

use crate::util::{random_blob, runtime_blob};

fn cfg(episodes: usize) -> EvalConfig {
    EvalConfig {
        episodes,
        ..EvalConfig::default()
    }
}

#[test]
fn blobs_of_several_shapes_boot_and_act_like_policy_core() {
    let blobs = [
        (random_blob::<32, 1>(1, "2x32"), 2, 32),
        (random_blob::<48, 3>(2, "4x48"), 4, 48),
        (random_blob::<64, 5>(3, "6x64"), 6, 64),
    ];
    let reference = Policy::<2, 48, 3, 2>::from_blob(&blobs[1].0).expect("4x48");
    for (blob, depth, width) in &blobs {
        let mut p = BlobPolicy::boot(blob).expect("boot");
        assert_eq!(
            (p.header().shape.depth, p.header().shape.width),
            (*depth, *width)
        );
        let mut a = [0.0f32; 2];
        p.act(&[1.5, -4.0], &mut a);
        assert!(a.iter().all(|v| v.is_finite() && v.abs() <= 0.25));
        if *width == 48 {
            // Bit for bit the same arithmetic as policy-core's own type.
            let direct = reference.act(&[1.5, -4.0]);
            assert_eq!(a.map(f32::to_bits), direct.map(f32::to_bits));
        }
    }
}

#[test]
fn a_random_4x48_policy_runs_the_full_protocol() {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let r = evaluate(&random_blob::<48, 3>(9, "random"), &s, &cfg(5)).expect("eval");
    assert!(r.boot_error.is_none());
    assert!(r.controller.contains("4x48"), "{}", r.controller);
    assert!(r.episodes.iter().all(|e| e.steps == 200 || e.left_arena));
    assert!(r.timing.mean_ns > 0.0);
}

#[test]
fn a_corrupted_blob_puts_the_loop_in_the_safe_state() {
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let mut blob = random_blob::<48, 3>(4, "corrupt me");
    let mid = blob.len() / 2;
    blob[mid] ^= 0x40;
    let r = evaluate(&blob, &s, &cfg(4)).expect("a report, not an error");
    let reason = r.boot_error.as_deref().expect("boot error");
    assert!(reason.contains("checksum"), "{reason}");
    assert!(!r.pass.passed && r.pass.failures[0].contains("did not boot"));
    // Zero action: nobody moves, nobody touches a wall, every test runs its 200 ticks.
    for e in &r.episodes {
        assert_eq!(e.start, e.end);
        assert_eq!((e.steps, e.contact_steps), (200, 0));
    }
    for bad in [&blob[..0], &blob[..10], b"DCPB\x01\x00garbage".as_slice()] {
        let r = evaluate(bad, &s, &cfg(1)).expect("a report");
        assert!(r.boot_error.is_some());
    }
}

fn shape(observations: u16, actions: u16, depth: u8, width: u16, choices: u16) -> Shape {
    Shape {
        observations,
        actions,
        width,
        depth,
        choices,
    }
}

/// No table of compiled shapes: shapes no build ever compiled (3x40,
/// 2x16, 1x7 relu) boot and act bit for bit like policy-core's runtime model.
#[test]
fn any_shape_boots_and_acts_like_the_runtime_model() {
    for (depth, width, activation) in [
        (3, 40, Activation::Tanh),
        (2, 16, Activation::Relu),
        (1, 7, Activation::Relu),
        (5, 64, Activation::Tanh),
    ] {
        let s = shape(2, 2, depth, width, 0);
        let blob = runtime_blob(ModelKind::Actor, s, activation, 11, "any");
        let mut p = BlobPolicy::boot(&blob).expect("boot");
        assert_eq!(p.header().shape, s);
        assert!(
            p.name().contains(&format!("{depth}x{width}")),
            "{}",
            p.name()
        );
        let model = Model::from_blob(&blob).expect("model");
        let mut scratch = Scratch::<64>::new();
        for obs in [[1.5, -4.0], [f32::NAN, 2.0], [f32::INFINITY, -1e30]] {
            let (mut a, mut b) = ([0.0f32; 2], [0.0f32; 2]);
            p.act(&obs, &mut a);
            model.act(&obs, &mut scratch, &mut b).expect("act");
            assert_eq!(
                a.map(f32::to_bits),
                b.map(f32::to_bits),
                "{depth}x{width} {obs:?}"
            );
            assert!(a.iter().all(|v| v.is_finite() && v.abs() <= 0.25));
        }
    }
}

/// The loop takes the sizes its plant declares: a 6-observation, 3-action blob boots for such a
/// plant and is refused, with a typed error, by the 2-by-2 navigation plant (which then runs in
/// the safe state and says why).
#[test]
fn a_blob_must_fit_the_sizes_its_plant_declares() {
    let blob = runtime_blob(
        ModelKind::Actor,
        shape(6, 3, 2, 24, 0),
        Activation::Tanh,
        3,
        "6x3",
    );
    let big = PlantSizes {
        observations: 6,
        actions: 3,
    };
    let mut p = boot(&blob, &big).expect("fits a 6x3 plant");
    let mut a = [9.0f32; 3];
    p.act(&[0.5; 6], &mut a);
    assert!(a.iter().all(|v| v.is_finite() && v.abs() <= 0.25));
    let nav = PlantSizes {
        observations: 2,
        actions: 2,
    };
    let e = boot(&blob, &nav).expect_err("does not fit navigation");
    assert_eq!(
        e,
        Error::SizeMismatch {
            what: "observation size",
            expected: 2,
            found: 6
        }
    );
    let s = Scenario::builtin("nav-open").expect("builtin");
    let r = evaluate(&blob, &s, &cfg(1)).expect("a report");
    let reason = r.boot_error.expect("boot error");
    assert_eq!(reason, "observation size: the plant needs 2, found 6");
    let two_by_one = runtime_blob(
        ModelKind::Actor,
        shape(2, 1, 2, 8, 0),
        Activation::Relu,
        4,
        "",
    );
    let e = boot(&two_by_one, &nav).expect_err("one action");
    assert!(matches!(
        e,
        Error::SizeMismatch {
            what: "action size",
            expected: 2,
            found: 1
        }
    ));
}

/// A discrete policy (DQN kind) runs in the loop: every action is a row of its table.
#[test]
fn a_discrete_blob_acts_with_rows_of_its_table() {
    let blob = runtime_blob(
        ModelKind::Discrete,
        shape(2, 2, 2, 16, 5),
        Activation::Relu,
        8,
        "dqn",
    );
    let mut p = BlobPolicy::boot(&blob).expect("boot");
    assert!(p.name().contains("discrete x5"), "{}", p.name());
    let rows = [-0.25, -0.125, 0.0, 0.125, 0.25];
    for obs in [[1.0, 2.0], [-5.0, 0.5], [f32::NAN, f32::NEG_INFINITY]] {
        let mut a = [9.0f32; 2];
        p.act(&obs, &mut a);
        assert!(rows.contains(&a[0]) && a[0] == a[1], "{a:?}");
    }
    let s = Scenario::builtin("nav-walls").expect("builtin");
    let r = evaluate(&blob, &s, &cfg(2)).expect("eval");
    assert!(r.boot_error.is_none(), "{:?}", r.boot_error);
    assert!(r.episodes.iter().all(|e| e.steps == 200 || e.left_arena));
}

#[test]
fn a_critic_blob_is_refused_as_the_wrong_kind() {
    let critic = runtime_blob(
        ModelKind::Critic,
        shape(2, 2, 4, 48, 0),
        Activation::Tanh,
        1,
        "c",
    );
    let e = BlobPolicy::boot(&critic).expect_err("not an actor");
    assert!(e.to_string().contains("expected actor"), "{e}");
    let s = Scenario::builtin("nav-open").expect("builtin");
    let r = evaluate(&critic, &s, &cfg(1)).expect("a report");
    assert!(r.boot_error.expect("boot error").contains("expected actor"));
}
