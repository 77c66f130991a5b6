use firmware_sim::controller::{BlobPolicy, Controller, SUPPORTED};
use firmware_sim::harness::{evaluate, EvalConfig};
use firmware_sim::scenario::Scenario;
use firmware_sim::Error;
use policy_core::{Critic, Policy};

use crate::util::random_blob;

fn cfg(episodes: usize) -> EvalConfig {
    EvalConfig {
        episodes,
        ..EvalConfig::default()
    }
}

#[test]
fn every_paper_shape_is_compiled() {
    assert_eq!(SUPPORTED.len(), 15);
    for (width, depth) in [(32, 2), (48, 4), (64, 6)] {
        assert!(SUPPORTED
            .iter()
            .any(|s| s.width == width && s.depth == depth));
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

#[test]
fn a_shape_not_compiled_is_named_with_the_supported_list() {
    let blob = Policy::<2, 16, 1, 2>::ZERO.to_blob("tiny").expect("blob");
    let e = BlobPolicy::boot(&blob).expect_err("16 wide is not compiled");
    assert!(matches!(e, Error::UnsupportedShape { .. }));
    let text = e.to_string();
    assert!(
        text.contains("2x16") && text.contains("width 48") && text.contains("{2,3,4,5,6}"),
        "{text}"
    );
    let s = Scenario::builtin("nav-open").expect("builtin");
    let r = evaluate(&blob, &s, &cfg(1)).expect("a report");
    assert!(r.boot_error.expect("boot error").contains("2x16"));
}

#[test]
fn a_critic_blob_is_refused_as_the_wrong_kind() {
    let critic = Critic::<2, 2, 48, 3>::ZERO.to_blob("critic").expect("blob");
    let e = BlobPolicy::boot(&critic).expect_err("not an actor");
    assert!(e.to_string().contains("expected actor"), "{e}");
}
