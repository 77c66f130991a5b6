//! `firmware-sim run`: the closed-loop test of a policy blob (or a reference controller) as a
//! CI gate; `firmware-sim match`: a badminton match between two players. Exit codes: 0 the
//! scenario's pass criteria hold, 1 they fail (or the blob did not boot), 2 bad input (one line
//! on stderr).
//!
//! Every input is checked, and every output path probed, before the first episode runs. Memory
//! does not grow with `--episodes`: the summary comes from running totals, and each episode's
//! record is streamed into the JSON report and the SVG plot as soon as it ends. Outputs appear
//! only when complete (written to temporary files and renamed into place).

use std::io;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::{Args, CommandFactory, Parser, Subcommand};
use firmware_sim::{out, outln};

use firmware_sim::actuator::ActuatorModel;
use firmware_sim::badminton::play::{play_match, Length, MeasuresReport};
use firmware_sim::badminton::{self, reference::PlayerKind};
use firmware_sim::boot::{boot_or_safe_state, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::files::{self, AtomicFile};
use firmware_sim::heads::HeadsPolicy;
use firmware_sim::hil::chip::{describe_boot, Backend, ChipOptions};
use firmware_sim::hil::link::{open_serial, Link};
use firmware_sim::hil::qemu::{self, slot_addresses, Machine};
use firmware_sim::hil::HilChip;
use firmware_sim::nav::generator;
use firmware_sim::nav::json_report::JsonReportWriter;
use firmware_sim::nav::metrics::EpisodeRecord;
use firmware_sim::nav::oracle::Oracle;
use firmware_sim::nav::reference::reference;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::svg::SvgWriter;
use firmware_sim::nav::test_protocol::{
    evaluate_controller, evaluate_streaming, EvalConfig, Report,
};
use firmware_sim::refine::RefiningPolicy;
use firmware_sim::sensor::SensorModel;
use firmware_sim::slots::{boot_slots, FIRMWARE_SCRATCH_WIDTH};
use policy_core::slot::SlotId;

#[derive(Parser, Debug)]
#[command(
    name = "firmware-sim",
    version,
    about = "Closed-loop firmware simulator for policy blobs"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Boot a blob (or a reference controller) and run the scenario's test protocol.
    // Boxed: the run's flags outweigh the match's many times (clippy::large_enum_variant).
    Run(Box<RunArgs>),
    /// Play a badminton match between two players and judge it by the scenario's criteria.
    Match(MatchArgs),
    /// Navigation layouts as scenario files.
    #[command(subcommand)]
    Scenario(ScenarioCommand),
    /// Play two badminton teams against each other: points between random pairings of their
    /// players, each team serving half; the teams' scores and each player's contribution.
    Teams(TeamsArgs),
    /// Draw a badminton critic's Q over the court as SVG: the catch critic over the targets it
    /// can ask for, the serve critic over the landing points of its serves.
    Heatmap(HeatmapArgs),
}

#[derive(Args, Debug)]
struct TeamsArgs {
    /// Team A: a trained team's folder (or its players/), a player folder, scripted or random.
    #[arg(long)]
    a: String,
    /// Team B, named the same ways.
    #[arg(long)]
    b: String,
    /// Points to play.
    #[arg(long, default_value_t = 1000)]
    points: u32,
    /// Seed of the pairings and of the reference players' noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Badminton scenario: badminton or a scenario file.
    #[arg(long, default_value = "badminton")]
    scenario: String,
    /// Write the result as JSON.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Args, Debug)]
#[command(group = clap::ArgGroup::new("source").required(true).args(["critic", "player"]))]
struct HeatmapArgs {
    /// The critic blob (a player's catch-critic.postcard or serve-critic.postcard).
    #[arg(long)]
    critic: Option<PathBuf>,
    /// A player folder: its manifest's critic for --role.
    #[arg(long)]
    player: Option<PathBuf>,
    /// Which agent's critic it is.
    #[arg(long, value_parser = ["catch", "serve"])]
    role: String,
    /// The SVG file to write.
    #[arg(long)]
    out: PathBuf,
    /// Grid steps per action dimension (catch: N×N targets; serve: N×N×N serves).
    #[arg(long, default_value_t = 41)]
    grid: usize,
    /// Badminton scenario: badminton or a scenario file.
    #[arg(long, default_value = "badminton")]
    scenario: String,
    /// The picture's title [default: the critic blob's label].
    #[arg(long)]
    title: Option<String>,
}

#[derive(Subcommand, Debug)]
enum ScenarioCommand {
    /// Generate a navigation layout the oracle solves from every start, as a scenario file.
    Generate(GenerateArgs),
}

#[derive(Args, Debug)]
struct GenerateArgs {
    /// The family: nested rings with gaps, or a maze of corridors.
    #[arg(long, value_enum)]
    kind: LayoutKind,
    /// Difficulty, 1 to 4: rings around the goal, or the maze's size (2·level + 1 cells a side).
    #[arg(long, default_value_t = 1)]
    level: u8,
    /// The layout's seed: the same seed, kind and level always give the same file.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The scenario file to write (TOML; run it with `firmware-sim run --scenario FILE`).
    #[arg(long)]
    out: PathBuf,
    /// Also draw the layout, with the oracle's paths from 20 starts, to this SVG file.
    #[arg(long)]
    svg: Option<PathBuf>,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
enum LayoutKind {
    Rings,
    Maze,
}

#[derive(Args, Debug)]
struct MatchArgs {
    /// Player 0: scripted, random, or a player folder (a directory holding player.toml and its
    /// three actor blobs).
    #[arg(long)]
    p0: PlayerKind,
    /// Player 1: scripted, random, or a player folder.
    #[arg(long)]
    p1: PlayerKind,
    /// Instead of a match: each player's catch test and serve test (--balls serves) and reset
    /// effect (--points points each way), against the other player.
    #[arg(long, conflicts_with_all = ["games", "svg"])]
    measures: bool,
    /// Serves of the catch and serve tests, 1..=1000000.
    #[arg(long, requires = "measures", default_value_t = 1000)]
    balls: u32,
    /// Points of the reset effect, each way, 1..=100000.
    #[arg(long, requires = "measures", default_value_t = 100)]
    points: u32,
    /// Games to play, 1..=1000.
    #[arg(long, default_value_t = 1)]
    games: u32,
    /// Seed of the players' random streams.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The badminton scenario: "badminton" (built in) or a TOML file.
    #[arg(long, default_value = "badminton")]
    scenario: String,
    /// Write the match report as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw one rally (the first of at least 4 hits, else the longest) from above and from the
    /// side to this SVG file.
    #[arg(long)]
    svg: Option<PathBuf>,
}

#[derive(Args, Debug)]
struct RunArgs {
    /// Policy blob to boot, as it would be flashed.
    #[arg(
        long,
        conflicts_with_all = ["controller", "slot_a", "slot_b"],
        required_unless_present_any = ["controller", "slot_a", "slot_b"]
    )]
    blob: Option<PathBuf>,
    /// Slot A's image (`host-trainer export --image bin --slot a`): with --slot-b, boots the newer
    /// slot that verifies, else the other, else the safe state, as the example firmware does.
    /// A slot not given is empty.
    #[arg(long, conflicts_with = "controller")]
    slot_a: Option<PathBuf>,
    /// Slot B's image (`host-trainer export --image bin --slot b`).
    #[arg(long, conflicts_with = "controller")]
    slot_b: Option<PathBuf>,
    /// The actor's critic blob (critic.postcard): with --refine, each action is DCP's compare
    /// step on the device (policy-core's `compare::refine_model`); with --heads, the critic
    /// chooses among the actor's heads (policy-core's `compare::choose_head`).
    /// (Both run from --blob only: a slot boot would run the plain actor, so --critic with
    /// --slot-a/--slot-b is refused.)
    #[arg(long, requires = "critic_use", conflicts_with_all = ["controller", "slot_a", "slot_b"])]
    critic: Option<PathBuf>,
    /// T,SIGMA: before each action, T proposals around the actor's unit action with noise σ,
    /// the best under the critic replacing it only if its Q is higher (needs --critic).
    #[arg(long, requires = "critic", group = "critic_use", value_parser = parse_refine)]
    refine: Option<(usize, f32)>,
    /// The blob is an actor of several heads (DCP's `heads`): it outputs a whole number of the
    /// plant's actions, and the critic (--critic) chooses one head each tick.
    #[arg(
        long,
        requires = "critic",
        group = "critic_use",
        conflicts_with = "hil"
    )]
    heads: bool,
    /// With --slot-a/--slot-b: the firmware's scratch width; a blob with a wider layer is refused
    /// as the chip refuses it [default: 64, the example firmware's].
    #[arg(long)]
    scratch_width: Option<usize>,
    /// A reference controller instead of a blob: straight or oracle.
    #[arg(long)]
    controller: Option<String>,
    /// Built-in scenario name (nav-walls, nav-open) or a TOML file.
    #[arg(long, default_value = "nav-walls")]
    scenario: String,
    /// Number of test starts, at most 1,000,000.
    #[arg(long, default_value_t = 100)]
    episodes: usize,
    /// Seed of every random stream.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Faults, comma-separated: dropout-nan:P, dropout-stale:P, stuck:D@T, wall:T@X0/Y0/X1/Y1[@I].
    /// At most one of each kind (dropout-nan and dropout-stale count as one kind).
    #[arg(long, default_value = "")]
    faults: String,
    /// Sensor noise standard deviation.
    #[arg(long, default_value_t = 0.0)]
    noise: f32,
    /// Sensor quantisation step.
    #[arg(long, default_value_t = 0.0)]
    quantum: f32,
    /// Deliver each sensor reading one tick late.
    #[arg(long)]
    delay: bool,
    /// Largest actuator change per tick and dimension.
    #[arg(long)]
    rate_limit: Option<f32>,
    /// Write the full JSON report here (every episode's record; with --svg, their trajectories).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Draw walls and every episode's trajectory to this SVG file.
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Hardware in the loop: the chip computes every action. qemu-m4f or qemu-m3: the HIL
    /// firmware under QEMU, with --blob (slot A, sequence 1) or --slot-a/--slot-b in its flash
    /// slots; serial:PATH: a board running the HIL firmware, its slots flashed with the same
    /// images (the chip's hello must name the blob the host boots from them).
    #[arg(long, value_parser = parse_hil, conflicts_with_all = ["controller", "critic", "scratch_width"])]
    hil: Option<HilTarget>,
    /// The HIL firmware ELF for --hil qemu-* [default: <target dir>/cortex-m/hil/m4f/firmware.elf
    /// (or m3), where `bash scripts/cortex-m.sh --hil-only` builds it].
    #[arg(long, requires = "hil")]
    hil_firmware: Option<PathBuf>,
    /// Serial speed for --hil serial:PATH.
    #[arg(long, requires = "hil", default_value_t = 115_200)]
    baud: u32,
    /// The longest wait, in seconds, for the chip's hello or for one tick's action.
    #[arg(long, requires = "hil", default_value_t = 5.0)]
    tick_timeout: f64,
    /// Fails the run (exit 1) if a tick takes more than this many instructions on the chip.
    #[arg(long, requires = "hil")]
    tick_budget: Option<u64>,
    /// One more argument for qemu-system-arm (repeatable; tests start a chip that never runs
    /// with -S, or add a monitor socket to reset it).
    #[arg(long, requires = "hil", hide = true, allow_hyphen_values = true)]
    hil_qemu_arg: Vec<String>,
}

/// Where `--hil` finds the chip.
#[derive(Clone, Debug)]
enum HilTarget {
    Qemu(Machine),
    Serial(String),
}

fn parse_hil(s: &str) -> Result<HilTarget, String> {
    match s {
        "qemu-m4f" => Ok(HilTarget::Qemu(Machine::M4f)),
        "qemu-m3" => Ok(HilTarget::Qemu(Machine::M3)),
        _ => match s.strip_prefix("serial:") {
            Some(path) if !path.is_empty() => Ok(HilTarget::Serial(path.to_string())),
            _ => Err(format!(
                "expected qemu-m4f, qemu-m3 or serial:PATH, found {s:?}"
            )),
        },
    }
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("{}", usage_error(&e));
            return ExitCode::from(2);
        }
    };
    let outcome = match &cli.command {
        Command::Run(args) => run(args),
        Command::Match(args) => play(args),
        Command::Scenario(ScenarioCommand::Generate(args)) => generate_layout(args),
        Command::Heatmap(args) => heatmap(args),
        Command::Teams(args) => teams(args),
    };
    match outcome {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// A command-line error as one line.
fn usage_error(e: &clap::Error) -> String {
    use clap::error::ErrorKind;
    if matches!(
        e.kind(),
        ErrorKind::MissingSubcommand | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
    ) {
        // clap prints the whole help here, whose first line does not say what is wrong.
        let cli = Cli::command();
        let names: Vec<&str> = cli.get_subcommands().map(|c| c.get_name()).collect();
        return format!(
            "{}: missing a subcommand: {} (see --help)",
            cli.get_name(),
            names.join(", ")
        );
    }
    // clap's message up to its usage block, folded into one line.
    let text = e.to_string();
    let head: Vec<&str> = text
        .lines()
        .take_while(|l| !l.trim().is_empty())
        .map(str::trim)
        .collect();
    head.join(" ")
}

/// Runs the evaluation; `Ok(passed)`. All input is checked before the first episode.
fn run(args: &RunArgs) -> Result<bool> {
    outputs_ok(args.json.as_deref(), args.svg.as_deref())?;
    if args.scratch_width.is_some() && args.slot_a.is_none() && args.slot_b.is_none() {
        // A blob boots with the width it declares; only the firmware's slot boot has a limit.
        anyhow::bail!("--scratch-width applies to slot boots only (--slot-a/--slot-b)");
    }
    let scenario = Scenario::resolve(&args.scenario).map_err(|e| {
        // A badminton scenario parses as a navigation scenario only up to its `[court]`.
        if badminton::Config::resolve(&args.scenario).is_ok() {
            anyhow::anyhow!(
                "{} is a badminton scenario: play it with `firmware-sim match --scenario {}`",
                args.scenario,
                args.scenario
            )
        } else {
            e.into()
        }
    })?;
    let cfg = eval_config(args)?;
    cfg.validate(&scenario)?;
    // The blob's bytes outlive the policy that runs from them, as flash outlives the firmware.
    let bytes = read_blob(args)?;
    let slots = [&args.slot_a, &args.slot_b].map(|p| read_slot(p.as_deref()));
    let [slot_a, slot_b] = slots;
    let (slot_a, slot_b) = (slot_a?, slot_b?);
    let critic = read_critic(args)?;
    if let Some(target) = &args.hil {
        let given = if args.blob.is_some() {
            Given::Blob(bytes.as_deref().unwrap_or_default())
        } else {
            Given::Slots(&slot_a, &slot_b)
        };
        return run_hil(args, target, &scenario, &cfg, given);
    }
    let (mut counts, mut head_counts) = (None, None);
    let (mut controller, boot_error) = if args.slot_a.is_some() || args.slot_b.is_some() {
        let boot = boot_slots(
            &slot_a,
            &slot_b,
            &PlantSizes::of(&scenario)?,
            args.scratch_width
                .unwrap_or(firmware_sim::slots::FIRMWARE_SCRATCH_WIDTH),
        )?;
        out!("{}", boot.describe());
        (boot.controller, boot.error)
    } else if let (Some(bytes), Some(critic), true) =
        (bytes.as_deref(), critic.as_deref(), args.heads)
    {
        let plant = PlantSizes::of(&scenario)?;
        match HeadsPolicy::boot(bytes, critic, &plant) {
            Ok(policy) => {
                head_counts = Some(policy.counts());
                (Box::new(policy) as Box<dyn Controller>, None)
            }
            Err(_) => HeadsPolicy::boot_or_safe_state(bytes, critic, &plant),
        }
    } else if let (Some(bytes), Some(critic), Some((t, sigma))) =
        (bytes.as_deref(), critic.as_deref(), args.refine)
    {
        let plant = PlantSizes::of(&scenario)?;
        match firmware_sim::boot::boot(bytes, &plant) {
            Ok(policy) => {
                let refining =
                    RefiningPolicy::new(policy.model().clone(), critic, t, sigma, args.seed)
                        .context("cannot run the compare step")?;
                counts = Some(refining.counts());
                (Box::new(refining) as Box<dyn Controller>, None)
            }
            Err(_) => boot_or_safe_state(bytes, &plant),
        }
    } else {
        controller(args, bytes.as_deref(), &scenario)?
    };
    let mut outputs = Outputs::create(args, &scenario, &controller.name())?;
    let mut report = evaluate_streaming(controller.as_mut(), &scenario, &cfg, |e| {
        outputs.episode(&e)
    })?;
    if let Some(e) = &boot_error {
        report.mark_boot_failure(e);
    }
    out!("{}", report.summary());
    if let Some((ticks, replaced)) = counts.map(|c| c.get()) {
        let share = replaced as f64 / ticks.max(1) as f64;
        outln!("  compare step                      a proposal replaced the actor's action on {replaced} of {ticks} ticks ({share:.3})");
    }
    if let Some(chosen) = head_counts.map(|c| c.get()) {
        let list: Vec<String> = chosen.iter().map(u64::to_string).collect();
        outln!(
            "  heads                             ticks on which each head was chosen: {}",
            list.join(", ")
        );
    }
    outputs.finish(&report)?;
    report_failures(&report, args.blob.as_deref());
    Ok(report.pass.passed)
}

/// What `--hil` loads into the chip's slots.
enum Given<'a> {
    Blob(&'a [u8]),
    Slots(&'a [u8], &'a [u8]),
}

/// `run --hil`: the same test protocol with the chip computing every action; `Ok(passed)`.
fn run_hil(
    args: &RunArgs,
    target: &HilTarget,
    scenario: &Scenario,
    cfg: &EvalConfig,
    given: Given<'_>,
) -> Result<bool> {
    let plant = PlantSizes::of(scenario)?;
    if !(args.tick_timeout.is_finite() && args.tick_timeout > 0.0 && args.tick_timeout <= 3600.0) {
        anyhow::bail!(
            "--tick-timeout must be in (0, 3600] seconds, found {}",
            args.tick_timeout
        );
    }
    let timeout = Duration::from_secs_f64(args.tick_timeout);
    let firmware = match target {
        HilTarget::Qemu(machine) => {
            let elf = hil_firmware(args, *machine)?;
            let slots = slot_addresses(&elf)?;
            Some((*machine, elf, slots))
        }
        HilTarget::Serial(_) => None,
    };
    // The slot size of the firmware's memory.x (a board's is the user's: the example's 128 KiB).
    let capacity = firmware
        .as_ref()
        .map_or(1 << 17, |(_, _, s)| s.size as usize);
    let (image_a, image_b) = match given {
        Given::Blob(blob) => (
            policy_core::slot::record(blob, 1, capacity)
                .context("--blob cannot go into a flash slot")?,
            Vec::new(),
        ),
        Given::Slots(a, b) => (a.to_vec(), b.to_vec()),
    };
    for (name, image) in [("--slot-a", &image_a), ("--slot-b", &image_b)] {
        if image.len() > capacity {
            anyhow::bail!(
                "{name}: {} bytes do not fit a slot of {capacity} bytes",
                image.len()
            );
        }
    }
    // The host boots the same slots with the firmware's rule and scratch width: the report's
    // controller is that blob, and the chip must say it runs the same one.
    let host = boot_slots(&image_a, &image_b, &plant, FIRMWARE_SCRATCH_WIDTH)?;
    let expected = host.running.map(|id| {
        let image = if id == SlotId::A { &image_a } else { &image_b };
        let blob = policy_core::slot::read(image)
            .map(|r| r.blob)
            .unwrap_or_default();
        let crc = blob.len().checked_sub(4).map_or(0, |at| {
            u32::from_le_bytes(blob[at..].try_into().unwrap_or_default())
        });
        (id, crc)
    });

    let interrupt = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&interrupt);
    ctrlc::set_handler(move || flag.store(true, Ordering::SeqCst))
        .context("cannot catch Ctrl-C")?;
    let (link_name, link, backend): (String, Box<dyn Link>, Option<Box<dyn Backend>>) =
        match (target, &firmware) {
            (HilTarget::Qemu(_), Some((machine, elf, slots))) => {
                let mut images = Vec::new();
                if !image_a.is_empty() {
                    images.push((slots.a, &image_a[..]));
                }
                if !image_b.is_empty() {
                    images.push((slots.b, &image_b[..]));
                }
                let (qemu, socket) =
                    qemu::start(*machine, elf, &images, &args.hil_qemu_arg, timeout)?;
                (
                    machine.name().to_string(),
                    Box::new(socket),
                    Some(Box::new(qemu)),
                )
            }
            (HilTarget::Serial(path), _) => {
                let port = open_serial(path, args.baud).map_err(firmware_sim::Error::Hil)?;
                (format!("serial:{path}"), Box::new(port), None)
            }
            (HilTarget::Qemu(_), None) => unreachable!("QEMU targets have a firmware"),
        };
    let options = ChipOptions {
        link_name: link_name.clone(),
        timeout,
        ask_hello: matches!(target, HilTarget::Serial(_)),
        interrupt: Some(interrupt),
        budget: args.tick_budget,
    };
    let name = host.controller.name();
    let mut chip = HilChip::connect(
        link,
        backend,
        options,
        name.clone(),
        plant.observations,
        plant.actions,
    )?;
    let hello = chip.hello().clone();
    let chip_runs = hello.running.as_ref().map(|r| {
        let id = match r.slot {
            hil_protocol::Slot::A => SlotId::A,
            hil_protocol::Slot::B => SlotId::B,
        };
        (id, r.blob_crc)
    });
    if chip_runs != expected {
        let says = |r: Option<(SlotId, u32)>| {
            r.map_or("the safe state".to_string(), |(id, crc)| {
                format!("slot {id} (blob CRC {crc:#010x})")
            })
        };
        anyhow::bail!(
            "{link_name}: the chip runs {}, but the slots given boot {} on the host ({}): flash the same images, or give the ones it runs",
            says(chip_runs),
            says(expected),
            describe_boot(&hello)
        );
    }
    let runs = host
        .running
        .map_or("no slot runs: safe state".to_string(), |id| {
            format!("slot {id} runs")
        });
    println!("{link_name}: {}; {runs}", describe_boot(&hello));

    let mut outputs = Outputs::create(args, scenario, &name)?;
    let mut report = evaluate_streaming(&mut chip, scenario, cfg, |e| outputs.episode(&e))?;
    if let Some(e) = &host.error {
        report.mark_boot_failure(e);
    }
    let chip_report = chip.report();
    // QEMU stops here, before the outputs are written.
    drop(chip);
    if chip_report.ticks_over_budget > 0 {
        report.pass.passed = false;
        report.pass.failures.push(format!(
            "{} ticks took more than the tick budget of {} instructions (the most: {})",
            chip_report.ticks_over_budget,
            chip_report.tick_budget.unwrap_or_default(),
            chip_report.instructions_max
        ));
    }
    report.chip = Some(chip_report);
    print!("{}", report.summary());
    outputs.finish(&report)?;
    report_failures(&report, args.blob.as_deref());
    Ok(report.pass.passed)
}

/// The HIL firmware ELF: `--hil-firmware`, else where scripts/cortex-m.sh builds it.
fn hil_firmware(args: &RunArgs, machine: Machine) -> Result<PathBuf> {
    if let Some(elf) = &args.hil_firmware {
        anyhow::ensure!(
            elf.is_file(),
            "--hil-firmware {}: no such file",
            elf.display()
        );
        return Ok(elf.clone());
    }
    let target_dir =
        std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| PathBuf::from("target"), PathBuf::from);
    let elf = machine.default_firmware(&target_dir);
    anyhow::ensure!(
        elf.is_file(),
        "no HIL firmware at {}: build it with `bash scripts/cortex-m.sh --hil-only` (or give --hil-firmware ELF)",
        elf.display()
    );
    Ok(elf)
}

/// `--svg` draws the first rally of at least this many hits.
const DRAWN_HITS: usize = 4;

/// The most games one `match` plays (a larger count is almost surely a typo).
const MAX_GAMES: u32 = 1000;

/// Plays the match; `Ok(passed)`. Inputs and output paths are checked before the first point.
fn play(args: &MatchArgs) -> Result<bool> {
    if !(1..=MAX_GAMES).contains(&args.games) {
        anyhow::bail!("--games must be in 1..={MAX_GAMES}, found {}", args.games);
    }
    outputs_ok(args.json.as_deref(), args.svg.as_deref())?;
    let config = badminton::Config::resolve(&args.scenario)?;
    let kinds = [args.p0.clone(), args.p1.clone()];
    if args.measures {
        return measures(args, &config, &kinds);
    }
    let mut drawn: Option<badminton::game::Rally> = None;
    let keep_rally = |game: &badminton::Badminton| {
        let hits = |r: &badminton::game::Rally| r.hits.len();
        let current = drawn.as_ref().map_or(0, hits);
        // The first rally of DRAWN_HITS hits or more (a readable figure), else the longest.
        if let Some(r) = game
            .rally()
            .filter(|r| current < DRAWN_HITS && hits(r) > current)
        {
            drawn = Some(r.clone());
        }
    };
    let length = Length::Games(args.games);
    let record = args.svg.is_some();
    let report = play_match(&config, &kinds, length, args.seed, record, keep_rally)?;
    out!("{}", report.summary());
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        written(files::write_atomic(path, text.as_bytes()), path)?;
    }
    if let (Some(path), Some(rally)) = (&args.svg, &drawn) {
        let end = rally.end.map_or("-".to_string(), |e| {
            let cause = serde_json::to_string(&e.cause).unwrap_or_default();
            let winner = e.winner.map_or("none".to_string(), |w| format!("p{w}"));
            format!("{}, point to {winner}", cause.trim_matches('"'))
        });
        let title = format!(
            "{} | p0 {} (blue) vs p1 {} (red) | seed {} | a rally of {} hits, ended by {end}",
            config.name,
            kinds[0],
            kinds[1],
            args.seed,
            rally.hits.len()
        );
        let svg = badminton::figure::rally_svg(rally, &config, &title);
        written(files::write_atomic(path, svg.as_bytes()), path)?;
    }
    if !report.pass.passed {
        eprintln!("FAIL: {}", report.pass.failures.join("; "));
    }
    Ok(report.pass.passed)
}

/// `match --measures`: `Ok(every agent booted)`.
fn measures(args: &MatchArgs, config: &badminton::Config, kinds: &[PlayerKind; 2]) -> Result<bool> {
    for (flag, n, most) in [
        ("--balls", args.balls, 1_000_000),
        ("--points", args.points, 100_000),
    ] {
        anyhow::ensure!(
            (1..=most).contains(&n),
            "{flag} must be in 1..={most}, found {n}"
        );
    }
    let report = MeasuresReport::of(config, kinds, args.balls, args.points, args.seed)?;
    out!("{}", report.summary());
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report)?;
        written(files::write_atomic(path, text.as_bytes()), path)?;
    }
    if !report.booted() {
        eprintln!("FAIL: an agent played the safe state (its blob did not boot)");
    }
    Ok(report.booted())
}

/// Generates a layout, checks it, writes it (and its picture); always `Ok(true)` once written.
fn generate_layout(args: &GenerateArgs) -> Result<bool> {
    outputs_ok(Some(&args.out), args.svg.as_deref())?;
    let kind = match args.kind {
        LayoutKind::Rings => generator::Kind::Rings,
        LayoutKind::Maze => generator::Kind::Maze,
    };
    let generated = generator::generate(kind, args.level, args.seed)?;
    let scenario = &generated.scenario;
    let text = format!(
        "# Generated by `firmware-sim scenario generate --kind {} --level {} --seed {}`: the\n\
         # oracle reaches the goal from each of {} test starts (seed {}).\n{}",
        kind.name(),
        args.level,
        args.seed,
        generator::CHECK_STARTS,
        args.seed,
        toml::to_string(scenario).context("cannot write the scenario as TOML")?
    );
    // What is written must read back as the same layout.
    let back = Scenario::from_toml_str(&text)?;
    anyhow::ensure!(
        back == *scenario,
        "the scenario does not round-trip through TOML"
    );
    written(files::write_atomic(&args.out, text.as_bytes()), &args.out)?;
    if let Some(path) = &args.svg {
        let cfg = EvalConfig {
            episodes: 20,
            seed: args.seed,
            record_trajectories: true,
            ..EvalConfig::default()
        };
        let mut oracle = Oracle::new(scenario);
        let report = evaluate_controller(&mut oracle, scenario, &cfg)?;
        let svg = firmware_sim::nav::svg::render(scenario, &report);
        written(files::write_atomic(path, svg.as_bytes()), path)?;
    }
    outln!(
        "{}: {} ({} walls; the oracle reaches the goal from all {} check starts)",
        args.out.display(),
        scenario.name,
        scenario.walls.len(),
        generator::CHECK_STARTS
    );
    Ok(true)
}

/// The outputs of one command, checked together before any work (writable, two different
/// files even when spelt differently), so a long run never ends in "cannot write" and never
/// writes one report over the other.
/// `teams`: both teams loaded and checked before the first point; exit 1 if a player's blob
/// did not boot (it played in the safe state).
fn teams(args: &TeamsArgs) -> Result<bool> {
    use firmware_sim::badminton::teams::{team_match, team_of};
    outputs_ok(args.json.as_deref(), None)?;
    let config = badminton::Config::resolve(&args.scenario)?;
    let teams = [team_of(&args.a)?, team_of(&args.b)?];
    let score = team_match(&config, &teams, args.points, args.seed)?;
    out!("{}", score.summary([&args.a, &args.b]));
    let mut booted = true;
    for (t, team) in teams.iter().enumerate() {
        for kind in team {
            for (role, e) in kind.boot_errors() {
                booted = false;
                outln!(
                    "  {} {kind} {}: safe state (blob did not boot: {e})",
                    ["A", "B"][t],
                    role.name()
                );
            }
        }
    }
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&score)? + "\n";
        written(files::write_atomic(path, text.as_bytes()), path)?;
    }
    Ok(booted)
}

/// `heatmap`: every input checked before the map is computed; the SVG written atomically.
fn heatmap(args: &HeatmapArgs) -> Result<bool> {
    use firmware_sim::badminton::heatmap;
    outputs_ok(None, Some(&args.out))?;
    let config = badminton::Config::resolve(&args.scenario)?;
    let (path, critic) = match (&args.critic, &args.player) {
        (Some(file), _) => {
            let bytes = files::read_blob(file)
                .with_context(|| format!("cannot read critic {}", file.display()))?;
            (file.clone(), bytes)
        }
        (None, Some(folder)) => {
            let player = firmware_sim::badminton::blob_player::PlayerFolder::load(folder)?;
            let role = if args.role == "catch" { 0 } else { 1 };
            let Some(critics) = player.critics else {
                anyhow::bail!(
                    "{}: the player's manifest names no critics",
                    folder.display()
                );
            };
            critics[role].clone()
        }
        (None, None) => anyhow::bail!("--critic or --player is required"),
    };
    let path = path.display();
    let map = match args.role.as_str() {
        "catch" => heatmap::catch_map(&config, &critic, args.grid),
        _ => heatmap::serve_map(&config, &critic, args.grid),
    }
    .with_context(|| format!("{path}"))?;
    let title = match &args.title {
        Some(t) => t.clone(),
        None => policy_core::model::Model::from_blob(&critic)?
            .header()
            .label
            .as_str()
            .to_string(),
    };
    let svg = heatmap::svg(&map, &config, &format!("{title}, {} critic", args.role))?;
    written(files::write_atomic(&args.out, svg.as_bytes()), &args.out)?;
    outln!("wrote {} ({} points)", args.out.display(), map.points.len());
    Ok(true)
}

fn outputs_ok(json: Option<&Path>, svg: Option<&Path>) -> Result<()> {
    let paths: Vec<&Path> = json.into_iter().chain(svg).collect();
    Ok(files::check_outputs(&paths)?)
}

fn eval_config(args: &RunArgs) -> Result<EvalConfig> {
    Ok(EvalConfig {
        episodes: args.episodes,
        seed: args.seed,
        sensor: SensorModel {
            noise_std: args.noise,
            quantum: args.quantum,
            delay: args.delay,
        },
        actuator: ActuatorModel {
            rate_limit: args.rate_limit,
        },
        faults: args.faults.parse()?,
        record_trajectories: args.svg.is_some(),
    })
}

/// The bytes of `--critic`, if given.
fn read_critic(args: &RunArgs) -> Result<Option<Vec<u8>>> {
    args.critic
        .as_ref()
        .map(|path| {
            files::read_blob(path).with_context(|| format!("cannot read critic {}", path.display()))
        })
        .transpose()
}

/// The bytes of `--blob`, if given.
fn read_blob(args: &RunArgs) -> Result<Option<Vec<u8>>> {
    args.blob
        .as_ref()
        .map(|path| {
            files::read_blob(path).with_context(|| format!("cannot read blob {}", path.display()))
        })
        .transpose()
}

/// `T,SIGMA`, checked here with the compare step's own rule, so a bad value is refused
/// whatever else is given (even with a blob that does not boot).
fn parse_refine(s: &str) -> Result<(usize, f32), String> {
    let parsed: Option<(usize, f32)> = s
        .split_once(',')
        .and_then(|(t, sigma)| Some((t.trim().parse().ok()?, sigma.trim().parse().ok()?)));
    let (t, sigma) =
        parsed.ok_or_else(|| format!("expected T,SIGMA such as 16,0.2, found {s:?}"))?;
    if !(sigma.is_finite() && sigma > 0.0) || t > firmware_sim::refine::MAX_T {
        return Err(format!(
            "expected T in 0..={} and SIGMA finite and > 0, found {s:?}",
            firmware_sim::refine::MAX_T
        ));
    }
    Ok((t, sigma))
}

/// The bytes of a slot image, or none (an empty slot) when the slot is not given.
fn read_slot(path: Option<&Path>) -> Result<Vec<u8>> {
    path.map_or(Ok(Vec::new()), |path| {
        files::read_slot(path).with_context(|| format!("cannot read slot image {}", path.display()))
    })
}

/// The booted blob (or the safe state and why the blob did not boot), or a reference controller.
fn controller<'a>(
    args: &RunArgs,
    blob: Option<&'a [u8]>,
    scenario: &Scenario,
) -> Result<(Box<dyn Controller + 'a>, Option<firmware_sim::Error>)> {
    match (blob, &args.controller) {
        (Some(bytes), _) => Ok(boot_or_safe_state(bytes, &PlantSizes::of(scenario)?)),
        (None, Some(name)) => Ok((reference(name, scenario)?, None)),
        (None, None) => anyhow::bail!("give --blob FILE or --controller straight|oracle"),
    }
}

/// The output files being written while the episodes run.
struct Outputs {
    json: Option<(JsonReportWriter, PathBuf)>,
    svg: Option<(SvgWriter<AtomicFile>, PathBuf)>,
}

impl Outputs {
    fn create(args: &RunArgs, scenario: &Scenario, controller: &str) -> Result<Outputs> {
        let json = args
            .json
            .as_ref()
            .map(|p| written(JsonReportWriter::create(p), p).map(|w| (w, p.clone())))
            .transpose()?;
        let svg = args
            .svg
            .as_ref()
            .map(|p| {
                let plot =
                    AtomicFile::create(p).and_then(|f| SvgWriter::start(f, scenario, controller));
                written(plot, p).map(|w| (w, p.clone()))
            })
            .transpose()?;
        Ok(Outputs { json, svg })
    }

    fn episode(&mut self, e: &EpisodeRecord) -> Result<()> {
        if let Some((json, path)) = &mut self.json {
            written(json.episode(e), path)?;
        }
        if let Some((svg, path)) = &mut self.svg {
            written(svg.episode(e), path)?;
        }
        Ok(())
    }

    /// Writes the summary into the JSON report and commits both files.
    fn finish(self, report: &Report) -> Result<()> {
        if let Some((svg, path)) = self.svg {
            written(svg.finish().and_then(AtomicFile::commit), &path)?;
        }
        if let Some((json, path)) = self.json {
            written(json.finish(report), &path)?;
        }
        Ok(())
    }
}

fn written<T>(result: io::Result<T>, path: &Path) -> Result<T> {
    result.with_context(|| format!("cannot write {}", path.display()))
}

fn report_failures(report: &Report, blob: Option<&Path>) {
    if let Some(reason) = &report.boot_error {
        let from = blob
            .map(|p| format!("{}: ", p.display()))
            .unwrap_or_default();
        eprintln!("error: {from}{reason} (ran in the safe state: zero action)");
    } else if !report.pass.passed {
        eprintln!("FAIL: {}", report.pass.failures.join("; "));
    }
}
