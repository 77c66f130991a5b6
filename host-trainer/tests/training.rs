//! Training runs with tiny budgets: smoke runs of every algorithm, determinism, resume, and
//! divergence handling. Every run here is small enough for the debug profile.

use host_trainer::algorithms::dcp::{Scoring, StateWeights, Variant};
use host_trainer::algorithms::ddpg::ActorGradient;
use host_trainer::algorithms::{Algo, Learner};
use host_trainer::nn::hidden::Hidden;
use host_trainer::nn::workers::Workers;
use host_trainer::run::checkpoint::Checkpoint;
use host_trainer::run::config::TrainConfig;
use host_trainer::run::folder::{self, RunDir};
use host_trainer::run::metrics;
use host_trainer::run::trainer::{self, Trainer};
use host_trainer::Error;

use crate::support::scratch;

fn train_to_end(config: TrainConfig, out: &std::path::Path) -> (Trainer, RunDir) {
    crate::support::train_trainer(Trainer::new(config).expect("trainer"), out)
}

#[test]
fn dcp_smoke_run_updates_and_writes_every_file() {
    let out = scratch("dcp-smoke");
    let (trainer, run) = train_to_end(TrainConfig::smoke(Algo::Dcp, 1), &out);
    trainer.export(&run).expect("export");
    assert_eq!(trainer.metrics.len(), 3);
    let stat = |name| trainer.last_stat(name).expect(name);
    assert!(
        stat("critic_loss").is_finite() && stat("actor_loss").is_finite(),
        "updates ran: {:?}",
        trainer.metrics.last()
    );
    let kept = stat("dcp_kept");
    assert!(kept > 0.0 && kept <= 1.0, "some proposals won: {kept}");
    for name in [
        folder::CONFIG,
        folder::METRICS,
        folder::CURVE,
        folder::CHECKPOINT,
        folder::POLICY,
        folder::CRITIC,
    ] {
        assert!(run.file(name).is_file(), "{name} written");
    }
    let csv = std::fs::read_to_string(run.file(folder::METRICS)).expect("metrics");
    assert_eq!(csv.lines().count(), 4, "header + 3 episodes:\n{csv}");
    let blob = std::fs::read(run.file(folder::POLICY)).expect("blob");
    policy_core::Policy::<2, 32, 1, 2>::from_blob(&blob).expect("the blob loads as a 2x32 policy");
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn ddpg_smoke_run_both_actor_gradients() {
    for gradient in [ActorGradient::Textbook, ActorGradient::NoisyAction] {
        let out = scratch("ddpg-smoke");
        let mut config = TrainConfig::smoke(Algo::Ddpg, 2);
        config.ddpg.actor_gradient = gradient;
        let (trainer, _) = train_to_end(config, &out);
        let stat = |name| trainer.last_stat(name);
        assert!(
            stat("critic_loss").is_some_and(f32::is_finite)
                && stat("actor_loss").is_some_and(f32::is_finite),
            "{gradient:?}: {:?}",
            trainer.metrics.last()
        );
        assert_eq!(stat("dcp_kept"), None, "DDPG has no kept column");
        std::fs::remove_dir_all(&out).expect("cleanup");
    }
}

#[test]
fn dcp_variants_train() {
    for variant in [Variant::Weighted, Variant::HillClimb] {
        let out = scratch("dcp-variants");
        let mut config = TrainConfig::smoke(Algo::Dcp, 3);
        config.dcp.variant = variant;
        let (trainer, _) = train_to_end(config, &out);
        let stat = |name| trainer.last_stat(name).expect(name);
        assert!(
            stat("actor_loss").is_finite() && stat("dcp_kept") > 0.0,
            "{variant:?}: {:?}",
            trainer.metrics.last()
        );
        std::fs::remove_dir_all(&out).expect("cleanup");
    }
}

#[test]
fn td3_smoke_run_has_twin_critics_delayed_actor_updates_and_exports_q1() {
    let out = scratch("td3-smoke");
    let (trainer, run) = train_to_end(TrainConfig::smoke(Algo::Td3, 2), &out);
    // The last networks (validation may keep an earlier round's): Q1 is the one compared.
    trainer.export_last(&run).expect("export");
    let stat = |name| trainer.last_stat(name);
    assert!(
        stat("critic_loss").is_some_and(f32::is_finite)
            && stat("actor_loss").is_some_and(f32::is_finite),
        "{:?}",
        trainer.metrics.last()
    );
    assert_eq!(stat("dcp_kept"), None, "TD3 has DDPG's columns");
    let Learner::ActorCritic(ac) = &trainer.learner else {
        panic!("TD3 is an actor-critic learner")
    };
    let twin = ac.agent.twin.as_ref().expect("twin critics");
    assert_ne!(twin.critic, ac.agent.critic, "Q2 is its own network");
    let critic = std::fs::read(run.file(folder::CRITIC)).expect("critic blob");
    let label = trainer.config.blob_label();
    assert_eq!(
        critic,
        ac.agent.critic_blob(&label).expect("Q1 blob"),
        "Q1 is exported"
    );
    // Delayed updates: the actor's Adam took half as many steps as the critics'.
    assert_eq!(ac.agent.actor_opt.steps * 2, ac.agent.critic_opt.steps);
    assert_eq!(twin.critic_opt.steps, ac.agent.critic_opt.steps);
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// A tiny run of the paper's DCP (every DCP-variant option off).
fn paper_smoke(seed: u64) -> TrainConfig {
    let mut c = TrainConfig::smoke(Algo::Dcp, seed);
    c.dcp = host_trainer::algorithms::dcp::Config {
        t: c.dcp.t,
        ..host_trainer::algorithms::dcp::Config::paper()
    };
    c
}

/// Every DCP-variant option on a tiny DCP run (and TD3), each changing one setting of the
/// paper's DCP.
fn dcp_variant_options() -> Vec<(&'static str, TrainConfig)> {
    type Edit = fn(&mut TrainConfig);
    let edits: [(&str, Edit); 13] = [
        ("softmax", |c| c.dcp.state_weights = StateWeights::Softmax),
        ("exp", |c| c.dcp.state_weights = StateWeights::Exp),
        ("binary", |c| c.dcp.state_weights = StateWeights::Binary),
        ("target", |c| c.dcp.scoring = Scoring::Target),
        ("twin-min", |c| c.dcp.scoring = Scoring::TwinMin),
        ("twin-min-smoothed", |c| {
            c.dcp.scoring = Scoring::TwinMin;
            c.dcp.target_smoothing = true;
        }),
        ("n-step-3", |c| c.dcp.n_step = 3),
        ("cem", |c| c.dcp.cem = true),
        ("trust-region", |c| {
            // A bound small enough to bind within a 4-episode run.
            c.dcp.trust_region = true;
            c.dcp.trust_region_kl = 1e-6;
        }),
        ("uniform-share", |c| c.dcp.uniform_share = 0.25),
        ("sigma-schedule", |c| c.agent.sigma_start = Some(1.0)),
        ("heads", |c| c.dcp.heads = 2),
        ("td3", |c| c.algo = Algo::Td3),
    ];
    edits
        .into_iter()
        .map(|(name, edit)| {
            let mut c = paper_smoke(5);
            c.episodes = 4;
            edit(&mut c);
            (name, c)
        })
        .collect()
}

/// Each option changes the run, the same seed gives the same blob bytes (actor and critic),
/// and stopping at the checkpoint and resuming equals the uninterrupted run.
#[test]
fn dcp_variant_options_are_deterministic_and_resume_exactly() {
    let out = scratch("dcp-variant-options");
    let blobs = |t: &Trainer| {
        let critic = t
            .algorithm()
            .critic_blob("x")
            .expect("a critic")
            .expect("blob");
        (t.policy_blob("x").expect("blob"), critic)
    };
    let paper = {
        let dir = out.join("paper");
        std::fs::create_dir_all(&dir).expect("dir");
        let mut c = paper_smoke(5);
        c.episodes = 4;
        blobs(&train_to_end(c, &dir).0)
    };
    for (name, config) in dcp_variant_options() {
        let dir = |sub: &str| {
            let d = out.join(format!("{name}-{sub}"));
            std::fs::create_dir_all(&d).expect("dir");
            d
        };
        let (whole, _) = train_to_end(config.clone(), &dir("a"));
        let (again, _) = train_to_end(config.clone(), &dir("b"));
        assert_eq!(
            blobs(&whole),
            blobs(&again),
            "{name}: same seed, same bytes"
        );
        assert_ne!(blobs(&whole).0, paper.0, "{name} changes the run");

        let mut first = config.clone();
        first.episodes = 2;
        let (_, run) = train_to_end(first, &dir("parts"));
        let path = run.file(folder::CHECKPOINT);
        let mut resumed = Trainer::resume(Checkpoint::load(&path).expect("load"), Some(4), &path)
            .expect("resume");
        trainer::run(&mut resumed, &run, &mut |_, _| {
            std::ops::ControlFlow::Continue(())
        })
        .expect("resumed training");
        assert_eq!(blobs(&resumed), blobs(&whole), "{name}: resume");
        let bits = |t: &Trainer| {
            (t.metrics.iter())
                .map(|r| r.stats.iter().map(|v| v.to_bits()).collect::<Vec<_>>())
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&resumed), bits(&whole), "{name}: metrics");
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// A checkpoint of a run with twin critics cannot continue under a config without them.
#[test]
fn a_twin_critic_checkpoint_refuses_a_config_without_twins() {
    let out = scratch("twin-mismatch");
    let mut config = TrainConfig::smoke(Algo::Dcp, 3);
    config.dcp.scoring = Scoring::TwinMin;
    config.episodes = 1;
    let (trainer, _) = train_to_end(config, &out);
    let mut learner = trainer.checkpoint().learner;
    let mut plain = paper_smoke(3);
    plain.episodes = 1;
    let err = learner
        .configure(&plain.sections())
        .expect_err("twin state, no twin config");
    assert!(err.contains("twin critics"), "{err}");
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// The margin study's candidate files (`experiments/margin/*.toml`): each is DCP's defaults
/// with its own options and nothing else, and each loads, validates and trains (2 episodes of
/// the smoke network).
#[test]
fn margin_candidate_files_set_their_options_only_and_train() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../experiments/margin");
    // The study's files have no [validation]: its protocol keeps the last networks.
    let defaults = TrainConfig {
        validation: None,
        ..TrainConfig::default()
    };
    type Check = fn(&TrainConfig) -> bool;
    let candidates: [(&str, Check); 4] = [
        ("sigma-schedule", |c| {
            c.agent.sigma_start == Some(1.0) && c.dcp.uniform_share == 0.0
        }),
        ("uniform-share", |c| {
            c.dcp.uniform_share == 0.25 && c.agent.sigma_start.is_none()
        }),
        ("uniform-sigma", |c| {
            c.dcp.uniform_share == 0.25 && c.agent.sigma_start == Some(1.0)
        }),
        ("heads", |c| c.dcp.heads == 2 && c.dcp.uniform_share == 0.0),
    ];
    let out = scratch("margin-files");
    for (name, check) in candidates {
        let mut config = TrainConfig::from_file(&dir.join(format!("{name}.toml"))).expect("loads");
        config.validate().expect("valid");
        assert!(check(&config), "{name}: its options");
        let mut back = config.clone();
        (
            back.agent.sigma_start,
            back.dcp.uniform_share,
            back.dcp.heads,
        ) = (None, 0.0, 1);
        assert_eq!(back, defaults, "{name}: nothing else changed");
        let smoke = TrainConfig::smoke(Algo::Dcp, 0);
        let sigma_start = config.agent.sigma_start;
        (config.agent, config.episodes, config.dcp.t) = (smoke.agent, 2, smoke.dcp.t);
        config.agent.sigma_start = sigma_start;
        config.eval_episodes = smoke.eval_episodes;
        let run = out.join(name);
        std::fs::create_dir_all(&run).expect("dir");
        let (trainer, _) = train_to_end(config, &run);
        assert!(
            trainer.last_stat("critic_loss").is_some_and(f32::is_finite),
            "{name}"
        );
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// The margin study's queue plan (`experiments/margin/plan.txt`, read by `queue.sh`) names only
/// arms and layouts that exist and holds every run of the protocol exactly once: 26 runs per
/// arm in the screening (pinwheel seeds 0–9, each of the 8 layouts seeds 0–1), and in the
/// confirmation 26 per agent on fresh seeds and layouts, for the winner step 2 named
/// (`uniform-share`), A0 and the four baselines. Lines marked `#recorded` count: their runs are
/// in the record.
#[test]
fn margin_plan_holds_every_run_of_the_protocol_once() {
    use std::collections::BTreeMap;
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../experiments/margin");
    let plan = std::fs::read_to_string(dir.join("plan.txt")).expect("plan");
    let layouts = (1..=4).flat_map(|l| [format!("rings-{l}"), format!("maze-{l}")]);
    let expected_tasks = |seeds: std::ops::RangeInclusive<u64>, layout_seeds: [u64; 2]| {
        let mut runs: Vec<(String, u64)> = seeds.map(|s| ("pinwheel".to_string(), s)).collect();
        for layout in layouts.clone() {
            runs.extend(layout_seeds.map(|s| (layout.clone(), s)));
        }
        runs.sort();
        runs
    };
    let mut runs: BTreeMap<(String, String), Vec<(String, u64)>> = BTreeMap::new();
    for line in plan.lines() {
        let line = line.strip_prefix("#recorded ").unwrap_or(line);
        if line.trim().is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split_whitespace().collect();
        let [step, arm, layout, seeds] = fields[..] else {
            panic!("not STEP ARM LAYOUT SEEDS: {line}")
        };
        let (folder, suffix) = match step {
            "screen" => ("layouts", "seed11"),
            "confirm" => ("confirm-layouts", "seed12"),
            _ => panic!("unknown step: {line}"),
        };
        assert!(
            ["A0", "ddpg", "td3", "ppo", "dqn"].contains(&arm)
                || dir.join(format!("{arm}.toml")).is_file(),
            "no such arm: {line}"
        );
        assert!(
            layout == "pinwheel"
                || dir
                    .join(folder)
                    .join(format!("{layout}-{suffix}.toml"))
                    .is_file(),
            "no such layout: {line}"
        );
        let (first, last) = seeds.split_once('-').expect("seeds as A-B");
        let (first, last): (u64, u64) = (first.parse().expect("A"), last.parse().expect("B"));
        let list = runs.entry((step.into(), arm.into())).or_default();
        list.extend((first..=last).map(|s| (layout.to_string(), s)));
    }
    for list in runs.values_mut() {
        list.sort();
    }
    let arms = |step: &str| -> Vec<&str> {
        runs.keys()
            .filter(|(s, _)| s == step)
            .map(|(_, a)| a.as_str())
            .collect()
    };
    assert_eq!(
        arms("screen"),
        [
            "A0",
            "heads",
            "sigma-schedule",
            "uniform-share",
            "uniform-sigma"
        ]
    );
    for arm in arms("screen") {
        assert_eq!(
            runs[&("screen".into(), arm.into())],
            expected_tasks(0..=9, [0, 1]),
            "{arm}"
        );
    }
    // The confirmation's agents: the winner step 2 named, A0 and the four baselines.
    let confirm = arms("confirm");
    assert_eq!(
        confirm,
        ["A0", "ddpg", "dqn", "ppo", "td3", "uniform-share"]
    );
    for arm in confirm {
        let want = expected_tasks(10..=19, [10, 11]);
        assert_eq!(runs[&("confirm".into(), arm.into())], want, "{arm}");
    }
}

/// The margin study's queue checks its whole plan before any run: a bad line anywhere, even
/// after good ones, stops it at once with one line naming what is wrong and exit code 2, before
/// it looks for the binary or takes the queue's lock (so this test never waits on a running
/// queue); an unreadable plan and a missing binary likewise.
#[test]
fn margin_queue_refuses_a_bad_plan_before_any_run() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = scratch("margin-queue");
    let queue = |plan: &std::path::Path, binary: &str| {
        std::process::Command::new("bash")
            .arg(root.join("experiments/margin/queue.sh"))
            .arg(plan)
            .env("HOST_TRAINER", binary)
            .output()
            .expect("bash runs")
    };
    let cases = [
        (
            "screen nope rings-1 0-1",
            "no config experiments/margin/nope.toml",
        ),
        (
            "screen A0 rings-9 0-1",
            "no layout experiments/margin/layouts/rings-9-seed11.toml",
        ),
        ("run A0 rings-1 0-1", "unknown step 'run'"),
        ("screen A0 rings-1", "is not 'STEP ARM LAYOUT SEEDS'"),
        (
            "confirm ddpg maze-1 10-11 12",
            "is not 'STEP ARM LAYOUT SEEDS'",
        ),
    ];
    for (line, needle) in cases {
        let plan = dir.join("plan.txt");
        std::fs::write(
            &plan,
            format!("# good first\nscreen A0 pinwheel 0-9\n\n{line}\n"),
        )
        .expect("plan");
        let out = queue(&plan, "/nonexistent/host-trainer");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{line}: {stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{line}: {stderr}");
        assert!(
            stderr.starts_with("queue.sh: ") && stderr.contains(needle),
            "{stderr}"
        );
        assert!(out.stdout.is_empty(), "{line}: nothing ran");
    }
    let good = dir.join("good.txt");
    std::fs::write(&good, "screen A0 pinwheel 0-9\n").expect("plan");
    let out = queue(&good, "/nonexistent/host-trainer");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("no host-trainer at /nonexistent"),
        "{stderr}"
    );
    let out = queue(&dir.join("missing.txt"), "/nonexistent/host-trainer");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("cannot read the plan"), "{stderr}");
    assert_eq!(out.status.code(), Some(2));
    std::fs::remove_dir_all(&dir).expect("cleanup");
}

/// A badminton team of three DCP players trains on its pairings, the same seed gives the same
/// player blobs, stopping and resuming equals the uninterrupted run, and DCP with another T
/// starts from the same weights; the exported players load as folders of a manifest and blobs
/// of each agent's shape.
#[test]
fn a_team_trains_resumes_exactly_and_exports_its_players() {
    use host_trainer::team::config::TeamConfig;
    use host_trainer::team::folder::{Outcome, TeamRun, MANIFEST};
    let out = scratch("team");
    let config = |t: usize| {
        let smoke = TrainConfig::smoke(Algo::Dcp, 0);
        let mut c = TeamConfig {
            players: 3,
            points: 60,
            checkpoint_every: 20,
            agent: smoke.agent,
            ..TeamConfig::default()
        };
        c.agent.warmup_steps = 8;
        c.dcp.t = t;
        c
    };
    let folder = |name: &str| {
        let d = out.join(name);
        std::fs::create_dir_all(&d).expect("dir");
        d
    };
    let blobs = |run: &TeamRun| -> Vec<Vec<u8>> {
        run.export().expect("export");
        (run.team.players.iter().enumerate())
            .flat_map(|(p, _)| ["catch", "serve", "reset"].map(move |r| (p, r)))
            .map(|(p, r)| {
                let file = run.dir.path().join(format!("players/p{p:02}/{r}.postcard"));
                std::fs::read(file).expect("blob")
            })
            .collect()
    };
    let go = |_: &host_trainer::team::training::Team| std::ops::ControlFlow::Continue(());
    let mut whole = TeamRun::create(config(4), &folder("a")).expect("team");
    assert_eq!(
        whole.train(&mut go.clone()).expect("train"),
        Outcome::Finished
    );
    let mut again = TeamRun::create(config(4), &folder("b")).expect("team");
    again.train(&mut go.clone()).expect("train");
    assert!(blobs(&whole) == blobs(&again), "same seed, same bytes");
    let t = whole.team.players[0].agents[1].get().stat_names();
    assert!(t.contains(&"critic_loss"));
    let csv = std::fs::read_to_string(whole.dir.file(folder::METRICS)).expect("metrics");
    assert_eq!(
        csv.lines().count(),
        4,
        "a header and one row per 20 points:\n{csv}"
    );
    let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
    let column = header
        .iter()
        .position(|&h| h == "serve_critic_loss")
        .expect("column");
    let last: Vec<&str> = csv.lines().last().expect("row").split(',').collect();
    let loss: f64 = last[column].parse().expect("a number");
    assert!(loss.is_finite(), "the serve learners updated:\n{csv}");

    // Stopped after 30 points, resumed to 60: the same team.
    let mut parts = TeamRun::create(config(4), &folder("parts")).expect("team");
    let mut stop = |t: &host_trainer::team::training::Team| {
        if t.points == 30 {
            std::ops::ControlFlow::Break(())
        } else {
            std::ops::ControlFlow::Continue(())
        }
    };
    assert_eq!(parts.train(&mut stop).expect("train"), Outcome::Stopped(30));
    // A flipped bit, or a run's checkpoint in its place, is a clear error.
    let file = parts.dir.file(folder::CHECKPOINT);
    let good = std::fs::read(&file).expect("checkpoint");
    let mut flipped = good.clone();
    flipped[good.len() / 2] ^= 0x10;
    std::fs::write(&file, &flipped).expect("write");
    let err = TeamRun::resume(parts.dir.path(), None)
        .expect_err("flipped")
        .to_string();
    assert!(err.contains("checksum mismatch"), "{err}");
    std::fs::write(&file, b"DCPCKPT5 not a team").expect("write");
    let err = TeamRun::resume(parts.dir.path(), None)
        .expect_err("a run's")
        .to_string();
    assert!(err.contains("not a team checkpoint"), "{err}");
    std::fs::write(&file, &good).expect("write");
    let mut resumed = TeamRun::resume(parts.dir.path(), None).expect("resume");
    resumed.train(&mut go.clone()).expect("train");
    assert!(blobs(&resumed) == blobs(&whole), "resume");

    // T changes the run, not the initialisation.
    let fresh = |t: usize, name: &str| TeamRun::create(config(t), &folder(name)).expect("team");
    let weights = |run: &TeamRun| -> Vec<Vec<u32>> {
        (blobs(run).iter())
            .map(|b| {
                let model = policy_core::model::Model::from_blob(b).expect("loads");
                model.values().map(f32::to_bits).collect()
            })
            .collect()
    };
    let (t1, t16) = (fresh(1, "t1"), fresh(16, "t16"));
    assert!(
        weights(&t1) == weights(&t16),
        "same initial weights for any T"
    );
    let mut t1 = t1;
    t1.train(&mut go.clone()).expect("train");
    assert!(
        weights(&t1) != weights(&whole),
        "T = 1 trains otherwise than T = 4"
    );

    let manifest = std::fs::read_to_string(whole.dir.path().join("players/p01").join(MANIFEST))
        .expect("manifest");
    assert!(manifest.contains("format = 1") && manifest.contains("serve = \"serve.postcard\""));
    for (role, actions) in [("catch", 2), ("serve", 3), ("reset", 2)] {
        let file = whole
            .dir
            .path()
            .join(format!("players/p01/{role}.postcard"));
        let bytes = std::fs::read(file).expect("blob");
        let model = policy_core::model::Model::from_blob(&bytes).expect("loads");
        model.expect_sizes(10, actions).expect("the agent's shape");
    }

    // firmware-sim plays the exported player as the trainer's learners act, bit for bit.
    use firmware_sim::badminton::agent::Player;
    use firmware_sim::badminton::blob_player::{BlobPlayer, PlayerFolder};
    use firmware_sim::badminton::play::{play_match, Length};
    use firmware_sim::badminton::reference::PlayerKind;
    use firmware_sim::badminton::Role;
    let path = whole.dir.path().join("players/p01");
    let folder = PlayerFolder::load(&path).expect("the player folder loads");
    let mut chip = BlobPlayer::boot(&folder);
    let obs = [1.0, -0.5, 1.5, -3.0, 0.5, 2.0, -2.0, 0.3, 2.5, -0.4];
    for (r, role) in Role::ALL.into_iter().enumerate() {
        let mut action = vec![0.0f32; role.actions()];
        chip.act(role, &obs, &mut action);
        let host = whole.team.players[1].agents[r].get().greedy(&obs);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&action), bits(&host), "{}", role.name());
    }
    let kinds = [
        path.to_str()
            .expect("utf-8")
            .parse::<PlayerKind>()
            .expect("a player folder"),
        PlayerKind::Scripted,
    ];
    let config = firmware_sim::badminton::Config::builtin();
    let report = play_match(&config, &kinds, Length::Points(5), 0, false, |_| {}).expect("match");
    assert_eq!(report.points, 5);
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// DDPG, TD3 and PPO teams train too (their learners update) and export players that load.
#[test]
fn every_team_algorithm_trains_and_exports() {
    use host_trainer::team::config::TeamConfig;
    use host_trainer::team::folder::TeamRun;
    let out = scratch("team-algos");
    for algo in [Algo::Ddpg, Algo::Td3, Algo::Ppo] {
        let smoke = TrainConfig::smoke(algo, 0);
        let mut config = TeamConfig {
            algo,
            players: 2,
            points: 40,
            agent: smoke.agent,
            ppo: smoke.ppo,
            ..TeamConfig::default()
        };
        config.agent.warmup_steps = 8;
        let mut run = TeamRun::create(config, &out).expect("team");
        run.train(&mut |_| std::ops::ControlFlow::Continue(()))
            .expect("train");
        let csv = run.metrics_csv();
        let header: Vec<&str> = csv.lines().next().expect("header").split(',').collect();
        let last: Vec<&str> = csv.lines().last().expect("row").split(',').collect();
        let updated = (header.iter().zip(&last))
            .filter(|(h, _)| h.starts_with("serve_") && *h != &"serve_reward")
            .any(|(_, v)| v.parse::<f64>().is_ok_and(f64::is_finite));
        assert!(updated, "{algo}: the serve learners updated\n{csv}");
        for folder in run.export().expect("export") {
            firmware_sim::badminton::blob_player::PlayerFolder::load(&folder).expect("loads");
        }
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// Bad team settings are refused before anything is written: fewer than two players, a budget
/// of 0 points, DQN, σ bounds the wrong way round.
#[test]
fn bad_team_settings_are_refused_before_a_folder_is_made() {
    use host_trainer::team::config::TeamConfig;
    use host_trainer::team::folder::TeamRun;
    let out = scratch("team-bad");
    type Edit = fn(&mut TeamConfig);
    let cases: [(Edit, &str); 5] = [
        (|c| c.players = 0, "players"),
        (|c| c.players = 1, "players"),
        (|c| c.points = 0, "points"),
        (|c| c.algo = Algo::Dqn, "algo"),
        (|c| (c.sigma_min, c.sigma_max) = (0.3, 0.2), "sigma_min"),
    ];
    for (edit, what) in cases {
        let mut config = TeamConfig::default();
        edit(&mut config);
        let err = TeamRun::create(config, &out)
            .expect_err("refused")
            .to_string();
        assert!(err.contains(what), "{err}");
        assert_eq!(
            std::fs::read_dir(&out).expect("out").count(),
            0,
            "nothing written"
        );
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// An actor of two heads acts in training exactly as firmware-sim runs its exported actor and
/// critic (the critic choosing the head), bit for bit, on ordinary and non-finite observations;
/// its checkpoint refuses a config of another head count.
#[test]
fn a_two_head_actor_acts_as_its_blobs_run() {
    use firmware_sim::boot::PlantSizes;
    use firmware_sim::controller::Controller;
    use firmware_sim::heads::HeadsPolicy;
    let out = scratch("two-heads");
    let mut config = paper_smoke(7);
    config.dcp.heads = 2;
    config.episodes = 3;
    let (trainer, run) = train_to_end(config, &out);
    // The last networks, which `greedy` below runs (validation may keep an earlier round's).
    trainer.export_last(&run).expect("export");
    let actor = std::fs::read(run.file(folder::POLICY)).expect("actor blob");
    let critic = std::fs::read(run.file(folder::CRITIC)).expect("critic blob");
    let plant = PlantSizes {
        observations: 2,
        actions: 2,
    };
    let mut policy = HeadsPolicy::boot(&actor, &critic, &plant).expect("boots");
    assert_eq!(policy.heads(), 2);
    let mut rng = firmware_sim::seed::training_stream(1, "observations");
    let special = [f32::NAN, f32::INFINITY, -f32::INFINITY, 1e30, -0.0];
    for i in 0..600 {
        let mut obs = [0.0f32; 2];
        for o in &mut obs {
            *o = 12.0 * firmware_sim::seed::uniform_f32(&mut rng) - 6.0;
        }
        if i % 50 == 0 {
            obs[i / 50 % 2] = special[i / 100 % special.len()];
        }
        let mut chip = [0.0f32; 2];
        policy.act(&obs, &mut chip);
        let host = trainer.algorithm().greedy(&obs);
        assert_eq!(
            chip.map(f32::to_bits).to_vec(),
            host.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            "observation {obs:?}"
        );
    }
    assert_eq!(policy.counts().get().iter().sum::<u64>(), 600);

    let mut learner = trainer.checkpoint().learner;
    let mut one = paper_smoke(7);
    one.episodes = 3;
    let err = learner
        .configure(&one.sections())
        .expect_err("two heads, one-head config");
    assert!(
        err.contains("1 actor head(s) and the checkpoint's actor has 2"),
        "{err}"
    );
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// The committed files of the DCP-variant study (`experiments/dcp-variants/`): each is the
/// pinwheel layout plus DCP options only, on top of the paper's DCP (one option per variant,
/// their union for the adopted combination, none for the baselines; `adopted-open` on the
/// no-walls layout), and each loads, validates and trains (2 episodes of the smoke network).
/// The adopted files are DCP's defaults.
#[test]
fn dcp_variant_files_each_set_one_option_and_train() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../experiments/dcp-variants");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("experiments/dcp-variants")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    assert!(
        files.len() >= 13,
        "nine variants, two baselines and the adopted pair: {files:?}"
    );
    let out = scratch("variant-files");
    for path in files {
        let name = path
            .file_stem()
            .expect("hand-made test value")
            .to_string_lossy()
            .into_owned();
        let mut config = TrainConfig::from_file(&path).expect("loads");
        config.validate().expect("valid");
        // The experiments' files have no [validation]: their protocols keep the last networks.
        let defaults = TrainConfig {
            task: config.task.clone(),
            validation: None,
            ..TrainConfig::default()
        };
        let paper = host_trainer::algorithms::dcp::Config::paper();
        if name.starts_with("baseline") {
            let expected = TrainConfig {
                dcp: paper,
                ..defaults
            };
            assert_eq!(config, expected, "{name}: the task and the paper's DCP");
            continue;
        }
        // Screening is on the pinwheel; the winner's copy for the no-walls confirmation
        // (protocol step 4) differs from `adopted.toml` in the task alone.
        let layout = if name == "adopted-open" {
            "nav-open"
        } else {
            "nav-walls"
        };
        assert_eq!(config.task, layout, "{name}: the layout");
        assert_ne!(config.dcp, paper, "{name}: DCP options set");
        if name.starts_with("adopted") {
            assert_eq!(config.dcp, defaults.dcp, "{name}: the adopted defaults");
        }
        assert_eq!(
            (&config.agent, config.episodes, config.algo),
            (&defaults.agent, defaults.episodes, Algo::Dcp),
            "{name}: nothing else changed"
        );
        let smoke = TrainConfig::smoke(Algo::Dcp, 0);
        (config.agent, config.episodes, config.dcp.t) = (smoke.agent, 2, smoke.dcp.t);
        config.eval_episodes = smoke.eval_episodes;
        let dir = out.join(&name);
        std::fs::create_dir_all(&dir).expect("dir");
        let (trainer, _) = train_to_end(config, &dir);
        let stat = trainer.last_stat("critic_loss").expect("critic_loss");
        assert!(stat.is_finite(), "{name}: updates ran");
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

const ALGOS: [Algo; 4] = [Algo::Dcp, Algo::Ddpg, Algo::Ppo, Algo::Dqn];

#[test]
fn same_seed_same_blob_bytes_other_seed_other_bytes() {
    let out = scratch("determinism");
    for algo in ALGOS {
        let blob = |seed: u64, sub: &str| {
            let dir = out.join(format!("{algo}-{sub}"));
            std::fs::create_dir_all(&dir).expect("dir");
            let (trainer, _) = train_to_end(TrainConfig::smoke(algo, seed), &dir);
            trainer.policy_blob("determinism").expect("blob")
        };
        let a = blob(7, "a");
        assert_eq!(
            a,
            blob(7, "b"),
            "{algo}: same seed and config must give the same bytes"
        );
        assert_ne!(a, blob(8, "c"), "{algo}");
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn resumed_run_equals_uninterrupted_run() {
    let out = scratch("resume");
    for algo in ALGOS {
        let whole = out.join(format!("{algo}-whole"));
        let parts = out.join(format!("{algo}-parts"));
        std::fs::create_dir_all(&whole).expect("dir");
        std::fs::create_dir_all(&parts).expect("dir");
        let mut config = TrainConfig::smoke(algo, 5);
        config.episodes = 4;
        let (uninterrupted, _) = train_to_end(config.clone(), &whole);

        // Stop after 2 episodes (the checkpoint interval), then resume from the file to 4.
        config.episodes = 2;
        let (_, run) = train_to_end(config, &parts);
        let path = run.file(folder::CHECKPOINT);
        let mut resumed = Trainer::resume(Checkpoint::load(&path).expect("load"), Some(4), &path)
            .expect("resume");
        assert_eq!(resumed.episode, 2);
        if let Learner::Ppo(ppo) = &resumed.learner {
            // The checkpoint falls inside a rollout: the test covers the unfinished one.
            assert!(!ppo.rollout.is_empty(), "a rollout in progress is saved");
        }
        trainer::run(&mut resumed, &run, &mut |_, _| {
            std::ops::ControlFlow::Continue(())
        })
        .expect("resumed training");

        assert_eq!(
            resumed.policy_blob("x").expect("blob"),
            uninterrupted.policy_blob("x").expect("blob"),
            "{algo}"
        );
        assert_eq!(resumed.metrics.len(), 4);
        let rows = |t: &Trainer| {
            t.metrics
                .iter()
                .map(|r| {
                    (
                        r.ret,
                        r.stats.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    )
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(rows(&resumed), rows(&uninterrupted), "{algo}");
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// PPO and DQN run end to end with tiny budgets: updates happen and report finite values.
#[test]
fn ppo_and_dqn_smoke_runs_update_and_export() {
    let out = scratch("ppo-dqn-smoke");
    for (algo, columns) in [
        (
            Algo::Ppo,
            &[
                "policy_loss",
                "value_loss",
                "entropy",
                "approx_kl",
                "clip_fraction",
            ][..],
        ),
        (Algo::Dqn, &["epsilon", "q_loss"][..]),
    ] {
        let mut config = TrainConfig::smoke(algo, 1);
        config.episodes = 6;
        let (trainer, run) = train_to_end(config, &out);
        // PPO: at least two rollouts of 32; DQN: past the warm-up of 16.
        let needed = if algo == Algo::Ppo { 64 } else { 17 };
        assert!(
            trainer.total_steps >= needed,
            "{algo}: {} steps",
            trainer.total_steps
        );
        assert_eq!(trainer.algorithm().stat_names(), columns);
        for name in columns {
            let v = trainer.last_stat(name).expect(name);
            assert!(v.is_finite(), "{algo} {name} = {v}");
        }
        trainer.export(&run).expect("export");
        assert!(run.file(folder::POLICY).is_file());
        assert!(
            !run.file(folder::CRITIC).exists(),
            "{algo} has no Q(s, a) critic to export"
        );
        let csv = std::fs::read_to_string(run.file(folder::METRICS)).expect("metrics");
        assert!(csv.starts_with(&metrics::csv_header(columns)), "{csv}");
        let kind = policy_core::model::Model::from_blob(
            &std::fs::read(run.file(folder::POLICY)).expect("blob"),
        )
        .expect("the blob boots")
        .header()
        .kind;
        let want = if algo == Algo::Dqn {
            policy_core::ModelKind::Discrete
        } else {
            policy_core::ModelKind::Actor
        };
        assert_eq!(kind, want);
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// DQN's ε falls from 1 to 0.05 over the first 10 % of the episodes of a real run.
#[test]
fn dqn_epsilon_follows_its_schedule_in_a_run() {
    let out = scratch("dqn-epsilon");
    let mut config = TrainConfig::smoke(Algo::Dqn, 2);
    config.episodes = 20;
    config.checkpoint_every = 20;
    config.task = "nav-open".into();
    let (trainer, _) = train_to_end(config, &out);
    let names = trainer.algorithm().stat_names();
    let eps: Vec<f32> = trainer
        .metrics
        .iter()
        .map(|r| r.stat(names, "epsilon").expect("epsilon"))
        .collect();
    assert_eq!(eps[0], 1.0);
    assert!((eps[1] - 0.525).abs() < 1e-6, "{eps:?}");
    assert!(eps[2..].iter().all(|&e| e == 0.05), "{eps:?}");
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn divergence_stops_with_a_clear_error_and_keeps_the_last_good_checkpoint() {
    let out = scratch("diverge");
    let mut config = TrainConfig::smoke(Algo::Ddpg, 4);
    config.episodes = 4;
    config.checkpoint_every = 1;
    // Start updating only in episode 2, so episode 1's checkpoint is good; then a learning rate
    // of 1e30 blows the critic up on the first update.
    config.agent.warmup_steps = 201;
    config.agent.lr_critic = 1e30;
    config.agent.lr_actor = 1e30;
    let mut trainer = Trainer::new(config).expect("trainer");
    let run = RunDir::create(&out, &trainer.config.run_name()).expect("run dir");
    let err = trainer::run(&mut trainer, &run, &mut |_, _| {
        std::ops::ControlFlow::Continue(())
    })
    .expect_err("must diverge");
    let message = err.to_string();
    assert!(matches!(err, Error::Diverged { .. }), "{message}");
    assert!(
        message.contains("diverged")
            && message.contains("not finite")
            && message.contains("checkpoint"),
        "{message}"
    );
    let kept = Checkpoint::load(&run.file(folder::CHECKPOINT))
        .expect("the last good checkpoint is readable");
    assert!(
        kept.learner.get().is_finite(),
        "the kept checkpoint holds finite weights"
    );
    assert!(
        kept.episode >= 1 && kept.episode < 4,
        "episode {}",
        kept.episode
    );
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn config_round_trips_through_toml_and_rejects_unknown_keys() {
    let mut c = TrainConfig::smoke(Algo::Dcp, 9);
    c.dcp.sigma_c = Some(0.5);
    let text = c.to_toml();
    assert_eq!(toml::from_str::<TrainConfig>(&text).expect("parse"), c);
    let bad = format!("{text}\nlearning_rat = 3\n");
    assert!(toml::from_str::<TrainConfig>(&bad).is_err());
}

#[test]
fn unsupported_shape_is_refused_before_training() {
    let mut c = TrainConfig::smoke(Algo::Dcp, 0);
    c.agent.hidden = Hidden {
        depth: 3,
        width: 2000,
    };
    let err = Trainer::new(c).expect_err("2000 wide is beyond the format's limit");
    assert!(err.to_string().contains("unsupported"), "{err}");
    assert!(
        err.to_string().contains("width must be in 1..=1024"),
        "{err}"
    );
}

/// sha256 of a file's bytes, as `sha256sum` prints it.
fn sha256(bytes: &[u8]) -> String {
    use sha2::Digest;
    sha2::Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The pin on training: the exported blobs (actor and critic, whole files) of 20-episode runs
/// of DCP (its defaults since the DCP-variants study), the paper's DCP and DDPG with `TrainConfig::smoke`. Any
/// change to the arithmetic of training, the random streams or the blob format changes these;
/// such a change must say so and show that learning did not get worse (README, "Training
/// speed").
///
/// The batched training pass fuses its multiply-adds where the build has FMA (the workspace's
/// x86-64-v3, or any newer level) and multiplies and adds without it (`-C target-cpu=x86-64`),
/// so there are two pins; every build of one kind gives the same bytes.
#[test]
fn training_blobs_are_bit_identical_to_the_pinned_run() {
    check_pin(1);
}

/// The same pin with the updates on 2 and 3 worker threads: the smoke config's 16 × 5 proposal
/// rows are split in two uneven parts per critic (4 tasks on 3 threads with twin critics), the
/// twin critics step side by side. Parallel work must not change a bit.
#[test]
fn training_blobs_are_the_pinned_bytes_for_any_thread_count() {
    check_pin(2);
    check_pin(3);
}

/// Trains the pinned runs with the updates on `threads` worker threads and compares their blobs
/// with the pin.
fn check_pin(threads: usize) {
    // (run, actor, critic) with FMA, then without.
    let fused = [
        (
            "dcp",
            "6229d39359239f9d09679545989e88876e5ebe4f2bb850e13c10dc24dafac217",
            "333d39c829ea671ffe09e4a09a1c4352a0f2c8aa4876140d3f4392e61e8cdac4",
        ),
        (
            "paper-dcp",
            "324c32c1485a397a7f991cfe3ebc8840873e76b4e2f39d5018d562e8298e891d",
            "bd3e4f7ca1b36826a8c1a767938a5225f5e8a6c8c03610aa5b878f32dfb64ecc",
        ),
        (
            "ddpg",
            "57fc6963031ab732a6eeb54687848515e5891cf5586ccde073b90e92cd868031",
            "e8922074dc4db9697b2c1199c54cb7875c0ba36058a53b0533f0cc05bf6d7ca3",
        ),
    ];
    let plain = [
        (
            "dcp",
            "a2c599d7365776278d489f6f672a5d4cd9fe6f0376501da59f16cabbcb8576c1",
            "c501a2fe54f75172769d17f75eace8cb2471b0fe1a2129c75cc0ed4c28b71a72",
        ),
        (
            "paper-dcp",
            "410d56d4dccfdfd73fd88a8097f04acb574cc616d8ac44c9044e89ac8ef589f6",
            "a5c1a4d696362dc327de07d12b91626f79fce9b148c4f0da0040735d9a78bfb1",
        ),
        (
            "ddpg",
            "3e07bd6af461136358682fe51a53a78c2fa8961a6b2bd647e3c0a4eaa83fa3ff",
            "ca0d7b4f4a7fef6cb9a994bb7a02e8991a317223064b4f92172447694649471a",
        ),
    ];
    let pinned = if cfg!(target_feature = "fma") {
        fused
    } else {
        plain
    };
    for (run, actor, critic) in pinned {
        let mut config = match run {
            "dcp" => TrainConfig::smoke(Algo::Dcp, 0),
            "paper-dcp" => paper_smoke(0),
            _ => TrainConfig::smoke(Algo::Ddpg, 0),
        };
        config.episodes = 20;
        let mut trainer = Trainer::new(config).expect("trainer");
        trainer.set_workers(Workers::new(threads).expect("worker threads"));
        while !trainer.done() {
            trainer.run_episode().expect("episode");
        }
        let blob = trainer.policy_blob("pin").expect("actor");
        assert_eq!(sha256(&blob), actor, "{run} actor blob, {threads} threads");
        let blob = trainer
            .algorithm()
            .critic_blob("pin")
            .expect("DCP and DDPG have a critic")
            .expect("critic");
        assert_eq!(
            sha256(&blob),
            critic,
            "{run} critic blob, {threads} threads"
        );
    }
}

/// A shape no build ever compiled trains and exports (no table of compiled shapes).
#[test]
fn a_3x40_network_trains_and_exports() {
    let out = scratch("train-3x40-lib");
    let mut c = TrainConfig::smoke(Algo::Ddpg, 1);
    c.agent.hidden = Hidden {
        depth: 3,
        width: 40,
    };
    let (trainer, run) = train_to_end(c, &out);
    let blob = trainer.export(&run).expect("export");
    let report = firmware_sim::nav::test_protocol::evaluate(
        &blob,
        trainer.plant.scenario().expect("a scenario run"),
        &firmware_sim::nav::test_protocol::EvalConfig {
            episodes: 2,
            ..Default::default()
        },
    )
    .expect("eval");
    assert_eq!(report.boot_error, None);
    assert!(report.controller.contains("3x40"), "{}", report.controller);
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// Guards the bug where a checkpoint from an older build decoded "successfully" into garbage
/// (postcard is not self-describing): the format carries a version in its magic.
#[test]
fn old_or_truncated_checkpoints_are_clear_errors() {
    let out = scratch("corrupt");
    let old = out.join("old.postcard");
    std::fs::write(&old, b"DCPCKPT2\x00\x01\x02").expect("write");
    let err = Checkpoint::load(&old).expect_err("old format");
    assert!(err.to_string().contains("older build"), "{err}");

    let mut config = TrainConfig::smoke(Algo::Dcp, 6);
    config.episodes = 1;
    let (trainer, _) = train_to_end(config, &out);
    let bytes = trainer.checkpoint().to_bytes().expect("encode");
    let cut = out.join("cut.postcard");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
    let err = Checkpoint::load(&cut).expect_err("truncated");
    assert!(err.to_string().contains("corrupt or truncated"), "{err}");
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// Regression: a checkpoint had a version but no checksum, so a flipped bit
/// in the middle was accepted by `--resume` and `export`.
#[test]
fn a_flipped_bit_anywhere_in_a_checkpoint_is_a_checksum_error() {
    let out = scratch("bitflip");
    let mut config = TrainConfig::smoke(Algo::Dcp, 8);
    config.episodes = 1;
    let (trainer, _) = train_to_end(config, &out);
    let bytes = trainer.checkpoint().to_bytes().expect("encode");
    assert!(Checkpoint::from_bytes(&bytes).is_ok());
    // 256 bits spread over everything past the magic, the first and last included (CRC-32
    // detects every single-bit error, so a sample shows the check is wired to the whole file).
    let (first, last) = (64, bytes.len() * 8 - 1);
    let mut flipped = bytes.clone();
    for i in 0..256 {
        let bit = first + (last - first) * i / 255;
        flipped[bit / 8] ^= 1 << (bit % 8);
        let err = Checkpoint::from_bytes(&flipped).expect_err("flipped bit accepted");
        assert!(err.contains("checksum mismatch"), "bit {bit}: {err}");
        flipped[bit / 8] ^= 1 << (bit % 8);
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// Regression: a run trained on a scenario file could not be resumed once
/// the file was gone, and silently continued on an edited one. The checkpoint holds the plant.
#[test]
fn a_checkpoint_carries_its_plant() {
    let out = scratch("plant");
    let task = out.join("mytask.toml");
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware-sim/scenarios/nav-open.toml"
    ))
    .expect("built-in scenario file");
    std::fs::write(&task, text.replace("time_limit = 200", "time_limit = 30")).expect("task");
    let mut config = TrainConfig::smoke(Algo::Dcp, 2);
    config.task = task.to_str().expect("utf-8").into();
    config.episodes = 2;
    let (trainer, run) = train_to_end(config, &out);
    std::fs::remove_file(&task).expect("delete the task file");
    let path = run.file(folder::CHECKPOINT);
    let mut resumed =
        Trainer::resume(Checkpoint::load(&path).expect("load"), Some(3), &path).expect("resume");
    assert_eq!(resumed.plant, trainer.plant);
    assert_eq!(
        resumed.plant.scenario().expect("a scenario run").time_limit,
        30
    );
    let episode = resumed
        .run_episode()
        .expect("an episode on the recorded plant");
    assert!(episode.steps <= 30);
    std::fs::remove_dir_all(&out).expect("cleanup");
}

#[test]
fn a_step_budget_ends_the_run_with_the_episode_that_reaches_it() {
    let out = scratch("step-budget");
    let mut config = TrainConfig::smoke(Algo::Dcp, 3);
    config.episodes = 50;
    config.env_steps = Some(150);
    let (trainer, run) = train_to_end(config, &out);
    let last = trainer.metrics.last().expect("episodes ran");
    assert!(trainer.total_steps >= 150, "{} steps", trainer.total_steps);
    assert!(
        trainer.total_steps - (last.steps as u64) < 150,
        "the run went on past the episode that reached the budget"
    );
    assert!(
        trainer.episode < 50,
        "the episode budget stays an upper bound"
    );
    let saved = std::fs::read_to_string(run.file(folder::CONFIG)).expect("config.toml");
    assert!(saved.contains("env_steps = 150"), "{saved}");

    // Without a step budget the config file does not mention one (older configs read alike).
    let plain = TrainConfig::smoke(Algo::Dcp, 3).to_toml();
    assert!(!plain.contains("env_steps"), "{plain}");
    let zero = TrainConfig {
        env_steps: Some(0),
        ..TrainConfig::smoke(Algo::Dcp, 3)
    };
    assert!(zero.validate().is_err());
    let _ = std::fs::remove_dir_all(&out);
}

/// An export killed mid-way left `players/` with some players and a player folder without its
/// manifest, which `firmware-sim teams` played as a smaller team. The players are written into
/// a hidden sibling first and put in place whole: what a killed export left there is removed,
/// and `players/` holds exactly the team's players.
#[test]
fn a_team_export_is_written_aside_and_put_in_place_whole() {
    use host_trainer::team::config::TeamConfig;
    use host_trainer::team::folder::{TeamRun, MANIFEST, PARTIAL_PLAYERS, PLAYERS};
    let out = scratch("team-export");
    let config = TeamConfig {
        players: 2,
        points: 4,
        agent: TrainConfig::smoke(Algo::Dcp, 0).agent,
        ..TeamConfig::default()
    };
    let run = TeamRun::create(config, &out).expect("team");
    let dir = run.dir.path().to_path_buf();
    // What a killed export leaves: a half-written hidden folder, and an old players/ holding a
    // player this team does not have.
    std::fs::create_dir_all(dir.join(PARTIAL_PLAYERS).join("p00")).expect("dir");
    std::fs::write(
        dir.join(PARTIAL_PLAYERS).join("p00/catch.postcard"),
        b"half",
    )
    .expect("write");
    std::fs::create_dir_all(dir.join(PLAYERS).join("p07")).expect("dir");
    let folders = run.export().expect("export");
    assert_eq!(folders, [dir.join("players/p00"), dir.join("players/p01")]);
    assert!(!dir.join(PARTIAL_PLAYERS).exists());
    let mut names: Vec<String> = std::fs::read_dir(dir.join(PLAYERS))
        .expect("players")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["p00", "p01"]);
    for folder in &folders {
        let manifest = std::fs::read_to_string(folder.join(MANIFEST)).expect("manifest");
        assert!(
            manifest.contains(&format!("--p0 {}", folder.display())),
            "the manifest names the folder it ends up in:\n{manifest}"
        );
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// PPO's actor was described as "4×48 tanh" in its module docs and the pages copied from them,
/// while its blob (like DDPG's and DCP's) has ReLU hidden layers and a tanh output only.
#[test]
fn ppos_actor_is_described_with_the_activation_its_blob_carries() {
    let out = scratch("ppo-activation");
    let (trainer, run) = train_to_end(TrainConfig::smoke(Algo::Ppo, 0), &out);
    trainer.export(&run).expect("export");
    let blob = std::fs::read(run.file(folder::POLICY)).expect("blob");
    let model = policy_core::model::Model::from_blob(&blob).expect("boots");
    assert_eq!(model.header().activation, policy_core::Activation::Relu);
    for (name, text) in [
        ("ppo.rs", include_str!("../src/algorithms/ppo.rs")),
        ("design.md", include_str!("../../docs/design.md")),
        ("training.md", include_str!("../../docs/training.md")),
    ] {
        assert!(!text.contains("4×48 tanh actor"), "{name}");
        assert!(text.contains("4×48 ReLU"), "{name}");
    }
    std::fs::remove_dir_all(&out).expect("cleanup");
}

/// Validation draws from no training stream: a run that validates learns the same networks,
/// episode for episode, as one that does not; the policy it keeps is exactly the blob of its
/// best round's networks; and the stop ends the run after `in_a_row` rounds meet the criteria.
#[test]
fn validation_changes_no_training_bit_and_keeps_the_best_rounds_blob() {
    let out = scratch("validation-kept");
    let mut config = TrainConfig::smoke(Algo::Dcp, 4);
    config.episodes = 8;
    let validation = config.validation.clone().expect("smoke validates");
    assert_eq!((validation.every, validation.starts), (2, 5));
    let (with, _) = train_to_end(config.clone(), &out.join("with"));
    assert_eq!(
        with.validation
            .iter()
            .map(|r| r.episode)
            .collect::<Vec<_>>(),
        [2, 4, 6, 8]
    );
    // The same run without validation, stopped at every round: the same networks.
    let mut plain = Trainer::new(TrainConfig {
        validation: None,
        ..config.clone()
    })
    .expect("trainer");
    let label = config.blob_label();
    let kept = with.kept.as_ref().expect("a kept policy");
    let mut at_kept = None;
    while !plain.done() {
        plain.run_episode().expect("episode");
        if plain.episode == kept.round.episode {
            at_kept = Some(plain.policy_blob(&label).expect("blob"));
        }
    }
    assert_eq!(
        plain.policy_blob(&label).expect("blob"),
        with.policy_blob(&label).expect("blob"),
        "validation changed what the run learned"
    );
    assert_eq!(
        Some(&kept.policy),
        at_kept.as_ref(),
        "the kept blob is its round's"
    );
    // The kept round is the best by the rule among every round.
    assert!(with.validation.iter().all(|r| !r.better_than(&kept.round)));
    // Criteria every round meets, on a gate every policy passes: the run stops at the second
    // round, as two in a row end it.
    let dir = out.join("lenient");
    std::fs::create_dir_all(&dir).expect("dir");
    let scenario = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../firmware-sim/scenarios/nav-open.toml"
    ))
    .expect("nav-open")
    .replace("min_success_rate = 0.9", "min_success_rate = 0.0")
    .replace("max_stuck_rate = 0.05", "max_stuck_rate = 1.0");
    let task = dir.join("lenient.toml");
    std::fs::write(&task, scenario).expect("scenario");
    let mut lenient = config;
    lenient.task = task.to_string_lossy().into_owned();
    if let Some(v) = lenient.validation.as_mut() {
        (v.min_success, v.max_stuck, v.max_error) = (0.0, 1.0, 100.0);
    }
    let (stopped, _) = train_to_end(lenient, &out.join("stopped"));
    assert!(stopped.stopped_at_gate());
    assert_eq!(stopped.episode, 4, "two rounds in a row end the run");
    let _ = std::fs::remove_dir_all(&out);
}

/// A checkpoint of the format before validation (`DCPCKPT5`) still reads, with no rounds and
/// no kept policy; this build writes `DCPCKPT6`.
#[test]
fn a_checkpoint_from_before_validation_still_reads() {
    let out = scratch("checkpoint-v5");
    let (trainer, _) = train_to_end(TrainConfig::smoke(Algo::Dcp, 5), &out);
    let now = trainer.checkpoint();
    assert!(now.to_bytes().expect("bytes").starts_with(b"DCPCKPT6"));
    let old = host_trainer::run::checkpoint::seal(
        b"DCPCKPT5",
        &(
            &now.config_toml,
            &now.scenario_toml,
            &now.learner,
            now.episode,
            now.total_steps,
            &now.metrics,
            &now.env_rng,
        ),
    )
    .expect("sealed");
    let read = Checkpoint::from_bytes(&old).expect("a DCPCKPT5 file reads");
    assert_eq!(
        (read.episode, read.total_steps),
        (now.episode, now.total_steps)
    );
    assert!(read.validation.is_empty() && read.kept.is_none());
    let _ = std::fs::remove_dir_all(&out);
}
