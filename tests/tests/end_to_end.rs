//! Train a tiny policy of every algorithm, export it, load the bytes in firmware-sim, run the
//! closed loop and check the report.

use firmware_sim::controller::{BlobPolicy, Controller};
use firmware_sim::nav::test_protocol::{evaluate, EvalConfig};
use host_trainer::algorithms::Algo;
use host_trainer::run::config::TrainConfig;
use host_trainer::run::folder::{self, RunDir};
use host_trainer::run::trainer::{self, Trainer};

#[test]
fn trained_blobs_of_every_algorithm_run_in_the_firmware_loop() {
    for algo in [Algo::Dcp, Algo::Ddpg, Algo::Td3, Algo::Ppo, Algo::Dqn] {
        trained_blob_runs_in_the_firmware_loop(algo);
    }
}

fn trained_blob_runs_in_the_firmware_loop(algo: Algo) {
    let out = std::env::temp_dir().join(format!("e2e-{algo}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    std::fs::create_dir_all(&out).expect("out dir");

    let mut config = TrainConfig::smoke(algo, 11);
    config.checkpoint_every = 3;
    config.eval_episodes = TrainConfig::default().eval_episodes;
    let mut trainer = Trainer::new(config).expect("trainer");
    let run = RunDir::create(&out, &trainer.config.run_name()).expect("run dir");
    trainer::run(&mut trainer, &run, &mut |_, _| {
        std::ops::ControlFlow::Continue(())
    })
    .expect("training");
    // The last networks, which `greedy` below runs (validation may have kept an earlier
    // round's; the kept policy is checked against its round's networks by the trainer's tests).
    trainer.export_last(&run).expect("export");

    // The bytes on disk, exactly as they would be flashed.
    let blob = std::fs::read(run.file(folder::POLICY)).expect("policy.postcard");

    // The firmware's policy (policy-core's runtime model over the bytes) acts exactly like the
    // trainer's own forward pass on its networks.
    let mut firmware = BlobPolicy::boot(&blob).expect("the blob boots");
    let mut greedy_differs = false;
    let first = trainer.algorithm().greedy(&[4.0, -5.5]);
    for obs in [
        [4.0f32, -5.5],
        [0.3, 0.2],
        [-5.9, 5.9],
        [0.0, 0.0],
        [5.75, 1.5],
        [-2.0, -5.75],
        [1e6, -1e6],
    ] {
        let mut action = [0.0f32; 2];
        firmware.act(&obs, &mut action);
        let greedy = trainer.algorithm().greedy(&obs);
        let bits = |a: &[f32]| a.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&action), bits(&greedy), "{algo} obs {obs:?}");
        greedy_differs |= greedy != first;
    }
    assert!(
        greedy_differs,
        "{algo}: the policy depends on the observation"
    );

    let scenario = trainer::scenario("nav-walls").expect("scenario");
    let report = evaluate(
        &blob,
        &scenario,
        &EvalConfig {
            episodes: 10,
            ..EvalConfig::default()
        },
    )
    .expect("evaluation");
    assert_eq!(report.boot_error, None);
    assert_eq!(report.episodes.len(), 10);
    for (name, rate) in [
        ("success", report.success_rate),
        ("strict", report.strict_reach_rate),
        ("stuck", report.stuck_rate),
        ("left", report.left_arena_rate),
    ] {
        assert!((0.0..=1.0).contains(&rate), "{name} rate {rate}");
    }
    assert!(
        report.mean_error.is_finite() && report.mean_error >= 0.0,
        "error {}",
        report.mean_error
    );
    assert!(report.total_steps > 0);
    std::fs::remove_dir_all(&out).expect("cleanup");
}
