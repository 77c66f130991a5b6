//! The host's side of the plant link against real plant processes: the C reference plant
//! (`plant-link-c/cart_on_rail.c`) and its fault plant (`plant-link-c/tests/faulty_plant.c`),
//! built with `cc` once per test run. Each fault must stop the plant with one line that names
//! the command, the request and what was expected, and no plant process may outlive its
//! `ChildPlant`, whatever the plant did.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use firmware_sim::env::{Env, Step};
use firmware_sim::plant_link::child::{ChildPlant, Timeouts};
use firmware_sim::Error;

/// The reset seed of every fault test; the faults come at this step after it.
const SEED: u64 = 7;
const FAULT_STEP: u64 = 3;

/// Generous for a C plant that answers in microseconds, on a loaded 2-core CI machine.
const TIMEOUTS: Timeouts = Timeouts {
    start: Duration::from_secs(20),
    step: Duration::from_secs(10),
};

/// The folder holding the built plants: compiled on first use, once per test binary run.
fn plants() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../plant-link-c");
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plant-link-c");
        std::fs::create_dir_all(&out).expect("the plants' folder");
        for (exe, main) in [
            ("cart_on_rail", "cart_on_rail.c"),
            ("faulty_plant", "tests/faulty_plant.c"),
        ] {
            // Built under a name of this process's own, then renamed over the old one: a
            // concurrent test run keeps the executable it started.
            let partial = out.join(format!("{exe}.{}", std::process::id()));
            let status = Command::new("cc")
                .args([
                    "-std=c99",
                    "-O2",
                    "-Wall",
                    "-Wextra",
                    "-Wpedantic",
                    "-Werror",
                ])
                .arg("-I")
                .arg(&src)
                .arg("-o")
                .arg(&partial)
                .arg(src.join(main))
                .arg(src.join("plant_link.c"))
                .status()
                .expect("cc runs (the C plants are part of the test suite)");
            assert!(status.success(), "cc refused {main}");
            std::fs::rename(&partial, out.join(exe)).expect("the plant in place");
        }
        out
    })
}

/// The command line of a built plant with `args`.
fn command(exe: &str, args: &str) -> String {
    let path = plants().join(exe);
    let path = path.to_str().expect("a UTF-8 temp path");
    assert!(!path.contains(char::is_whitespace), "{path:?} would split");
    format!("{path} {args}").trim_end().to_string()
}

fn faulty(args: &str) -> String {
    command("faulty_plant", args)
}

/// The proportional-derivative controller that parks the cart on its target.
fn settle(observation: &[f32]) -> f32 {
    let (x, v, target) = (observation[0], observation[1], observation[2]);
    (2.0 * (target - x) - 2.0 * v).clamp(-1.0, 1.0)
}

/// Whether process `pid` exists (running or a zombie not yet reaped).
fn alive(pid: u32) -> bool {
    Path::new(&format!("/proc/{pid}")).exists()
}

/// Drops the plant and checks that its process went with it (one that exited may be gone
/// already: the host reaps it to read its exit status).
fn close(plant: ChildPlant) {
    let pid = plant.id();
    drop(plant);
    assert!(!alive(pid), "plant process {pid} outlived its ChildPlant");
}

/// Runs the fault plant with `args` to its fault at step [`FAULT_STEP`] after reset(seed
/// [`SEED`]); its one-line error.
fn error_at_fault(args: &str, timeouts: Timeouts) -> String {
    let command = faulty(args);
    let mut plant = ChildPlant::spawn(&command, timeouts).expect("a good hello");
    let mut observation = plant.reset(SEED);
    for n in 1..FAULT_STEP {
        let step = plant.step(&[settle(&observation)]);
        assert!(plant.failure().is_none(), "{args}: step {n} failed early");
        assert!(!step.terminated, "{args}: the cart never terminates");
        observation = step.observation;
    }
    let step = plant.step(&[settle(&observation)]);
    assert!(step.terminated, "{args}: a failed plant ends its episode");
    assert_eq!(step.observation, [0.0; 3], "{args}: the ended step's zeros");
    let failure = plant.failure().expect("the fault is recorded");
    assert!(
        matches!(&failure, Error::Plant { plant, .. } if *plant == command),
        "{failure:?}"
    );
    // Failed, the plant ends every episode at once and never answers again.
    assert_eq!(plant.reset(SEED), [0.0; 3]);
    assert!(plant.step(&[0.0]).terminated);
    close(plant);
    let line = failure.to_string();
    assert!(!line.contains('\n'), "one line: {line:?}");
    line
}

/// The one-line error of a plant whose hello is refused, and a check that it left nothing
/// running (the `ChildPlant` inside `spawn` was dropped before the error came back).
fn spawn_error(args: &str) -> String {
    let command = faulty(args);
    let e = ChildPlant::spawn(&command, TIMEOUTS).expect_err("the hello is refused");
    assert!(
        matches!(&e, Error::Plant { plant, .. } if *plant == command),
        "{e:?}"
    );
    assert!(
        running_children(&command).is_empty(),
        "{command} left running"
    );
    e.to_string()
}

/// This process's children whose command line is `command` (tests run in parallel threads, so
/// a test can only look for its own plant's arguments).
fn running_children(command: &str) -> Vec<u32> {
    let me = std::process::id();
    let wanted: Vec<u8> = command
        .split(' ')
        .flat_map(|a| [a.as_bytes(), &[0]].concat())
        .collect();
    std::fs::read_dir("/proc")
        .expect("/proc")
        .flatten()
        .filter_map(|e| e.file_name().to_str()?.parse::<u32>().ok())
        .filter(|pid| {
            let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
            // The parent pid is the second field after the parenthesised name.
            let ppid = stat
                .rsplit_once(')')
                .and_then(|(_, rest)| rest.split_whitespace().nth(1)?.parse::<u32>().ok());
            let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
            ppid == Some(me) && cmdline.ends_with(&wanted)
        })
        .collect()
}

fn expected(args: &str, at: &str, what: &str) -> String {
    format!("plant {:?}: {at}: {what}", faulty(args))
}

const AT: &str = "step 3 after reset(seed 7)";

#[test]
fn a_plant_that_exits_mid_episode_is_named_with_its_status() {
    let args = "--exit-at-step 3";
    assert_eq!(
        error_at_fault(args, TIMEOUTS),
        expected(args, AT, "it exited with status 3 before answering")
    );
}

#[test]
fn a_plant_that_hangs_is_a_time_out_and_is_killed() {
    let args = "--hang-at-step 3";
    let started = Instant::now();
    let timeouts = Timeouts {
        step: Duration::from_millis(500),
        ..TIMEOUTS
    };
    assert_eq!(
        error_at_fault(args, timeouts),
        expected(
            args,
            AT,
            "no answer within 0.5 s (the step timeout; the plant hangs or is too slow)"
        )
    );
    // The time-out, then Drop's second of grace before the kill: not a hung host.
    assert!(
        started.elapsed() < Duration::from_secs(5),
        "{:?}",
        started.elapsed()
    );
}

#[test]
fn garbage_on_the_plants_output_is_a_garbled_frame() {
    let args = "--garbage-at-step 3";
    assert_eq!(
        error_at_fault(args, TIMEOUTS),
        expected(
            args,
            AT,
            "sent a garbled frame (invalid COBS), expected a step answer"
        )
    );
}

#[test]
fn an_observation_of_the_wrong_size_is_refused() {
    let args = "--wrong-size-at-step 3";
    assert_eq!(
        error_at_fault(args, TIMEOUTS),
        expected(
            args,
            AT,
            "an observation of 2 values, expected 3 (the hello's box)"
        )
    );
}

#[test]
fn a_nan_observation_is_refused() {
    let args = "--nan-at-step 3";
    assert_eq!(
        error_at_fault(args, TIMEOUTS),
        expected(
            args,
            AT,
            "an observation whose value 0 is NaN, expected a finite number"
        )
    );
}

#[test]
fn an_infinite_reward_is_refused() {
    let args = "--inf-reward-at-step 3";
    assert_eq!(
        error_at_fault(args, TIMEOUTS),
        expected(args, AT, "a reward of inf, expected a finite number")
    );
}

#[test]
fn a_plants_error_answer_is_passed_on() {
    let args = "--error-at-step 3";
    assert_eq!(
        error_at_fault(args, TIMEOUTS),
        expected(args, AT, "the plant says: the cart's motor driver tripped")
    );
}

#[test]
fn a_plant_that_exits_at_start_fails_the_hello() {
    let args = "--exit-at-start";
    let line = spawn_error(args);
    // Whether the hello reached the pipe before the plant was gone is a race; either way the
    // line names the request and the exit status.
    let sent = expected(args, "hello", "it exited with status 3 before answering");
    let unsent = expected(
        args,
        "hello",
        "it exited with status 3 before the request could be sent",
    );
    assert!(line == sent || line == unsent, "{line}");
}

#[test]
fn frames_of_another_protocol_version_are_refused_by_name() {
    let args = "--version 2";
    assert_eq!(
        spawn_error(args),
        expected(
            args,
            "hello",
            "sent a frame of plant protocol version 2; this side speaks version 1, expected a \
             hello answer"
        )
    );
}

#[test]
fn bad_boxes_in_the_hello_are_refused_with_the_dimension() {
    for (kind, why) in [
        (
            "empty",
            "declares an action box whose dimension 0 is empty: [0.5, 0.5]",
        ),
        (
            "inverted",
            "declares an action box whose dimension 0 is inverted: [1, -1]",
        ),
        (
            "infinite",
            "declares an action box whose dimension 0 is infinite (an action box must be \
             finite): [-1, inf]",
        ),
        (
            "nan",
            "declares an observation box whose dimension 0 is NaN: [NaN, 1]",
        ),
        (
            "mismatched",
            "declares an observation box of 3 lows and 2 highs",
        ),
    ] {
        let args = format!("--box {kind}");
        let line = spawn_error(&args);
        assert_eq!(line, format!("plant {:?}: its hello {why}", faulty(&args)));
    }
}

#[test]
fn a_plant_of_two_agents_is_refused() {
    let args = "--agents 2";
    assert_eq!(
        spawn_error(args),
        format!(
            "plant {:?}: its hello declares 2 agents; this version of the plant link runs \
             plants of exactly one",
            faulty(args)
        )
    );
}

#[test]
fn a_command_that_does_not_exist_is_one_line() {
    let e = ChildPlant::spawn("/nonexistent/cart_on_rail --fast", TIMEOUTS)
        .expect_err("no such program");
    assert_eq!(
        e.to_string(),
        "plant \"/nonexistent/cart_on_rail --fast\": cannot start: no such file \
         /nonexistent/cart_on_rail"
    );
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../plant-link-c/cart_on_rail.c");
    let source = source.to_str().expect("a UTF-8 path");
    let e = ChildPlant::spawn(source, TIMEOUTS).expect_err("C source is no program");
    assert_eq!(
        e.to_string(),
        format!("plant {source:?}: cannot start: {source} is not an executable file")
    );
}

#[test]
fn a_plant_that_ignores_close_leaves_when_its_input_ends() {
    let command = faulty("--ignore-close");
    let mut plant = ChildPlant::spawn(&command, TIMEOUTS).expect("a good hello");
    // The search that proves other tests' plants gone finds this one while it runs.
    assert_eq!(running_children(&command), [plant.id()]);
    plant.reset(SEED);
    plant.step(&[1.0]);
    let started = Instant::now();
    close(plant);
    // Drop kills only after a second of grace: quicker, the plant left on its own.
    assert!(
        started.elapsed() < Duration::from_millis(900),
        "{:?}: the plant did not leave at the end of its input",
        started.elapsed()
    );
}

/// One episode of the cart under the settling controller, or a constant `push`.
fn episode(plant: &mut ChildPlant, seed: u64, push: Option<f32>) -> Vec<Step> {
    let mut observation = plant.reset(seed);
    let mut steps = Vec::new();
    loop {
        let action = push.unwrap_or_else(|| settle(&observation));
        let step = plant.step(&[action]);
        assert!(plant.failure().is_none(), "{:?}", plant.failure());
        observation = step.observation.clone();
        let done = step.terminated || step.truncated;
        steps.push(step);
        if done {
            return steps;
        }
    }
}

/// A trajectory as bits: equal only if every value is the same float.
fn bits(steps: &[Step]) -> Vec<Vec<u32>> {
    steps
        .iter()
        .map(|s| {
            let flags = [s.terminated, s.truncated, s.info.margin_touched];
            let mut v: Vec<u32> = s.observation.iter().map(|x| x.to_bits()).collect();
            v.push(s.reward.to_bits());
            v.extend(s.info.applied.iter().map(|x| x.to_bits()));
            v.extend(flags.map(u32::from));
            v.push(s.info.success.map_or(2, u32::from));
            v
        })
        .collect()
}

#[test]
fn the_cart_gives_the_same_trajectory_for_the_same_seed() {
    let cart = command("cart_on_rail", "");
    let mut first = ChildPlant::spawn(&cart, TIMEOUTS).expect("the cart starts");
    assert_eq!(first.hello().name, "cart-on-rail");
    assert_eq!(first.hello().agents[0].action_low, [-1.0]);
    let a = episode(&mut first, SEED, None);
    // Another process, and a reset in between: only the seed decides.
    let mut second = ChildPlant::spawn(&cart, TIMEOUTS).expect("the cart starts");
    episode(&mut second, SEED + 1, None);
    let b = episode(&mut second, SEED, None);
    assert_eq!(bits(&a), bits(&b));
    assert_ne!(bits(&a), bits(&episode(&mut second, SEED + 1, None)));
    // 200 steps, never terminal, and the settling controller holds the target at the end.
    assert_eq!(a.len(), 200);
    assert!(a.iter().all(|s| !s.terminated));
    assert!(a[..199].iter().all(|s| !s.truncated));
    assert_eq!(a[199].info.success, Some(true));
    assert_eq!(a[0].info.success, Some(false));
    close(first);
    close(second);
}

#[test]
fn the_cart_pushed_into_its_end_touches_the_margin_and_applies_nothing() {
    let mut plant =
        ChildPlant::spawn(&command("cart_on_rail", ""), TIMEOUTS).expect("the cart starts");
    let steps = episode(&mut plant, SEED, Some(1.0));
    let first = steps
        .iter()
        .position(|s| s.info.margin_touched)
        .expect("a full push reaches the end");
    assert!(steps[..first].iter().all(|s| s.info.applied == [1.0]));
    for s in &steps[first..] {
        assert_eq!(s.observation[..2], [1.0, 0.0], "stopped dead at the end");
        assert!(s.info.margin_touched);
        assert_eq!(s.info.applied, [0.0], "the end stop takes the force");
    }
    // An action outside the box is clipped to it, not refused.
    plant.reset(SEED);
    assert_eq!(plant.step(&[-3.0]).info.applied, [-1.0]);
    close(plant);
}
