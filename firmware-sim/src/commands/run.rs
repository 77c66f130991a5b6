//! `firmware-sim run`: the closed-loop test of a policy blob (or a reference controller, or
//! the firmware image itself with `--hil`) as a CI gate.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::{errln, out, outln};

use firmware_sim::actuator::ActuatorModel;
use firmware_sim::badminton;
use firmware_sim::boot::{boot_or_safe_state, PlantSizes};
use firmware_sim::controller::Controller;
use firmware_sim::files::{self, AtomicFile};
use firmware_sim::heads::HeadsPolicy;
use firmware_sim::hil::chip::{describe_boot, Backend, ChipOptions, ChipReport};
use firmware_sim::hil::link::{open_serial, Link};
use firmware_sim::hil::qemu::{self, slot_addresses, Machine};
use firmware_sim::hil::HilChip;
use firmware_sim::nav::faults::Faults;
use firmware_sim::nav::json_report::JsonReportWriter;
use firmware_sim::nav::metrics::EpisodeRecord;
use firmware_sim::nav::reference::reference;
use firmware_sim::nav::scenario::Scenario;
use firmware_sim::nav::svg::SvgWriter;
use firmware_sim::nav::test_protocol::{evaluate_streaming, EvalConfig, Report};
use firmware_sim::pass::PassOutcome;
use firmware_sim::plant_link::child::{ChildPlant, Timeouts};
use firmware_sim::plant_test::{evaluate_plant, Criteria, PlantTestConfig, SuccessRule};
use firmware_sim::refine::RefiningPolicy;
use firmware_sim::sensor::SensorModel;
use firmware_sim::slots::{boot_slots, FIRMWARE_SCRATCH_WIDTH};
use policy_core::slot::SlotId;

use super::{outputs_ok, written};

#[derive(Args, Debug)]
pub(crate) struct RunArgs {
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
    /// A plant of your own instead of a scenario: "CMD ARGS" starts it as a child process that
    /// speaks the plant link on its standard input and output (docs/own-plant.md). The test is
    /// then the protocol for any plant: success by the plant's flag or --success-return, the
    /// margin figures, and --faults dropout and stuck.
    #[arg(long, conflicts_with_all = ["controller", "critic", "svg"])]
    plant_cmd: Option<String>,
    /// With --plant-cmd: the longest wait, in seconds, for the plant's answer to a reset or step.
    #[arg(long, requires = "plant_cmd", default_value_t = 10.0)]
    plant_timeout: f64,
    /// With --plant-cmd: an episode's success is a return of at least this (instead of the
    /// plant's own success flag).
    #[arg(long, requires = "plant_cmd", allow_hyphen_values = true)]
    success_return: Option<f64>,
    /// With --plant-cmd: the smallest success rate that passes.
    #[arg(long, requires = "plant_cmd", default_value_t = 0.8)]
    min_success: f64,
    /// With --plant-cmd: the largest stuck-at-margin rate that passes.
    #[arg(long, requires = "plant_cmd", default_value_t = 0.2)]
    max_stuck: f64,
    /// With --plant-cmd: the longest test episode, in steps (a plant that never ends its
    /// episodes is cut here).
    #[arg(long, requires = "plant_cmd", default_value_t = 1000)]
    max_steps: u32,
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
    /// Serial speed for --hil serial:PATH, in baud [default: 115200].
    #[arg(long, requires = "hil", value_parser = clap::value_parser!(u32).range(1..))]
    baud: Option<u32>,
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

/// `--baud` when not given: the HIL firmware's UART speed.
const DEFAULT_BAUD: u32 = 115_200;

/// Where `--hil` finds the chip.
#[derive(Clone, Debug)]
pub(crate) enum HilTarget {
    Qemu(Machine),
    Serial(String),
}

pub(crate) fn parse_hil(s: &str) -> Result<HilTarget, String> {
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

/// Runs the evaluation; `Ok(passed)`. All input is checked before the first episode.
pub(crate) fn run(args: &RunArgs) -> Result<bool> {
    hil_flags_ok(args)?;
    outputs_ok(args.json.as_deref(), args.svg.as_deref())?;
    if let Some(command) = &args.plant_cmd {
        return run_on_plant(args, command);
    }
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

/// `run --plant-cmd`: the test protocol for any plant, on a plant process; `Ok(passed)`.
pub(crate) fn run_on_plant(args: &RunArgs, command: &str) -> Result<bool> {
    let cfg = plant_test_config(args)?;
    let timeouts = Timeouts {
        step: seconds("--plant-timeout", args.plant_timeout)?,
        ..Timeouts::default()
    };
    let bytes = read_blob(args)?;
    let [slot_a, slot_b] = [&args.slot_a, &args.slot_b].map(|p| read_slot(p.as_deref()));
    let (slot_a, slot_b) = (slot_a?, slot_b?);
    let mut plant = ChildPlant::spawn(command, timeouts)?;
    let sizes = PlantSizes::of_env(&plant);
    cfg.validate(sizes.actions)?;
    let name = plant.hello().name.clone();
    let given = || match &bytes {
        Some(blob) => Given::Blob(blob),
        None => Given::Slots(&slot_a, &slot_b),
    };
    let mut report = if let Some(target) = &args.hil {
        let (mut chip, host_error) = connect_chip(args, target, &sizes, given())?;
        let mut report = evaluate_plant(&mut chip, &mut plant, &name, &cfg)?;
        if let Some(e) = &host_error {
            report.mark_boot_failure(e);
        }
        report.chip = Some(finish_chip(chip, &mut report.pass));
        report
    } else {
        let (mut controller, boot_error) = match given() {
            Given::Blob(blob) => boot_or_safe_state(blob, &sizes),
            Given::Slots(a, b) => {
                let width = args.scratch_width.unwrap_or(FIRMWARE_SCRATCH_WIDTH);
                let boot = boot_slots(a, b, &sizes, width)?;
                out!("{}", boot.describe());
                (boot.controller, boot.error)
            }
        };
        let mut report = evaluate_plant(controller.as_mut(), &mut plant, &name, &cfg)?;
        if let Some(e) = &boot_error {
            report.mark_boot_failure(e);
        }
        report
    };
    drop(plant);
    if report.stopped.is_some() {
        // The plant or the chip failed: the totals are those of the episodes that ran.
        report.pass.passed = false;
    }
    out!("{}", report.summary());
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report).context("cannot write the report")?;
        written(files::write_atomic(path, text.as_bytes()), path)?;
    }
    if let Some(reason) = &report.boot_error {
        errln!("error: {reason} (ran in the safe state: zero action)");
    } else if !report.pass.passed {
        errln!("FAIL: {}", report.pass.failures.join("; "));
    }
    Ok(report.pass.passed)
}

/// The test settings of `run --plant-cmd`.
fn plant_test_config(args: &RunArgs) -> Result<PlantTestConfig> {
    let faults: Faults = args.faults.parse()?;
    anyhow::ensure!(
        faults.wall.is_none(),
        "--faults wall:... moves navigation's walls; a plant from --plant-cmd takes the dropout \
         and stuck faults"
    );
    let success = args
        .success_return
        .map_or(SuccessRule::PlantFlag, SuccessRule::ReturnAtLeast);
    Ok(PlantTestConfig {
        episodes: args.episodes,
        seed: args.seed,
        max_steps: args.max_steps,
        sensor: SensorModel {
            noise_std: args.noise,
            quantum: args.quantum,
            delay: args.delay,
        },
        actuator: ActuatorModel {
            rate_limit: args.rate_limit,
        },
        dropout: faults.dropout,
        stuck_actuator: faults.stuck,
        criteria: Criteria {
            success,
            min_success_rate: args.min_success,
            max_stuck_rate: args.max_stuck,
            ..Criteria::default()
        },
    })
}

/// A time in seconds from a flag, in (0, 3600].
fn seconds(flag: &str, s: f64) -> Result<Duration> {
    anyhow::ensure!(
        s.is_finite() && s > 0.0 && s <= 3600.0,
        "{flag} must be in (0, 3600] seconds, found {}",
        firmware_sim::error::number(s)
    );
    Ok(Duration::from_secs_f64(s))
}

/// What `--hil` loads into the chip's slots.
pub(crate) enum Given<'a> {
    Blob(&'a [u8]),
    Slots(&'a [u8], &'a [u8]),
}

/// `run --hil`: the same test protocol with the chip computing every action; `Ok(passed)`.
pub(crate) fn run_hil(
    args: &RunArgs,
    target: &HilTarget,
    scenario: &Scenario,
    cfg: &EvalConfig,
    given: Given<'_>,
) -> Result<bool> {
    let plant = PlantSizes::of(scenario)?;
    let (mut chip, host_error) = connect_chip(args, target, &plant, given)?;
    let mut outputs = Outputs::create(args, scenario, &chip.name())?;
    let mut report = evaluate_streaming(&mut chip, scenario, cfg, |e| outputs.episode(&e))?;
    if let Some(e) = &host_error {
        report.mark_boot_failure(e);
    }
    let chip_report = finish_chip(chip, &mut report.pass);
    report.chip = Some(chip_report);
    print!("{}", report.summary());
    outputs.finish(&report)?;
    report_failures(&report, args.blob.as_deref());
    Ok(report.pass.passed)
}

/// The chip's report at the end of a HIL run, its tick budget judged into `pass`; QEMU stops
/// here, before the caller writes its outputs.
pub(crate) fn finish_chip(chip: HilChip, pass: &mut PassOutcome) -> ChipReport {
    let chip_report = chip.report();
    drop(chip);
    if chip_report.ticks_over_budget > 0 {
        pass.passed = false;
        pass.failures.push(format!(
            "{} ticks took more than the tick budget of {} instructions (the most: {})",
            chip_report.ticks_over_budget,
            chip_report.tick_budget.unwrap_or_default(),
            chip_report.instructions_max
        ));
    }
    chip_report
}

/// Starts (QEMU) or opens (a board) the chip with the given slots, checks that it runs what the
/// host boots from them with the firmware's rule and scratch width, and returns it with the
/// host's boot error (the safe state's reason), if any.
pub(crate) fn connect_chip(
    args: &RunArgs,
    target: &HilTarget,
    plant: &PlantSizes,
    given: Given<'_>,
) -> Result<(HilChip, Option<firmware_sim::Error>)> {
    let timeout = seconds("--tick-timeout", args.tick_timeout)?;
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
    let host = boot_slots(&image_a, &image_b, plant, FIRMWARE_SCRATCH_WIDTH)?;
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
                let baud = args.baud.unwrap_or(DEFAULT_BAUD);
                let port = open_serial(path, baud).map_err(firmware_sim::Error::Hil)?;
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
    let chip = HilChip::connect(
        link,
        backend,
        options,
        name.clone(),
        plant.observations,
        plant.actions,
    )?;
    let hello = chip.hello().clone();
    // The chip runs any blob within its maxima at the blob's sizes; one for another plant would
    // be refused tick by tick, so say so once, with both sizes.
    if let Some(r) = &hello.running {
        let blob = (usize::from(r.observations), usize::from(r.actions));
        if blob != (plant.observations, plant.actions) {
            anyhow::bail!(
                "{link_name}: the chip runs slot {:?}, a policy of (observations, actions) = {blob:?}; the plant's are ({}, {}): flash a policy for this plant",
                r.slot,
                plant.observations,
                plant.actions
            );
        }
    }
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

    Ok((chip, host.error))
}

/// Refuses the `--hil` flags that the chosen link would ignore: a speed for QEMU's UART, an ELF
/// for a board (which runs what is flashed on it).
fn hil_flags_ok(args: &RunArgs) -> Result<()> {
    match &args.hil {
        Some(HilTarget::Qemu(machine)) if args.baud.is_some() => anyhow::bail!(
            "--baud sets a serial port's speed; --hil {} has none: drop --baud, or give --hil serial:PATH",
            machine.name()
        ),
        Some(HilTarget::Serial(path)) if args.hil_firmware.is_some() => anyhow::bail!(
            "--hil-firmware is the ELF that QEMU runs; the board on serial:{path} runs the firmware flashed on it: drop --hil-firmware, or give --hil qemu-m4f|qemu-m3"
        ),
        _ => Ok(()),
    }
}

/// The HIL firmware ELF: `--hil-firmware`, else where scripts/cortex-m.sh builds it.
pub(crate) fn hil_firmware(args: &RunArgs, machine: Machine) -> Result<PathBuf> {
    if let Some(elf) = &args.hil_firmware {
        anyhow::ensure!(
            !elf.is_dir(),
            "--hil-firmware {}: a folder, not an ELF file: give the firmware's ELF, such as {}",
            elf.display(),
            machine.default_firmware(Path::new("target")).display()
        );
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

pub(crate) fn eval_config(args: &RunArgs) -> Result<EvalConfig> {
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
pub(crate) fn read_critic(args: &RunArgs) -> Result<Option<Vec<u8>>> {
    args.critic
        .as_ref()
        .map(|path| {
            files::read_blob(path).with_context(|| format!("cannot read critic {}", path.display()))
        })
        .transpose()
}

/// The bytes of `--blob`, if given.
pub(crate) fn read_blob(args: &RunArgs) -> Result<Option<Vec<u8>>> {
    args.blob
        .as_ref()
        .map(|path| {
            files::read_blob(path).with_context(|| format!("cannot read blob {}", path.display()))
        })
        .transpose()
}

/// `T,SIGMA`, checked here with the compare step's own rule, so a bad value is refused
/// whatever else is given (even with a blob that does not boot).
pub(crate) fn parse_refine(s: &str) -> Result<(usize, f32), String> {
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
pub(crate) fn read_slot(path: Option<&Path>) -> Result<Vec<u8>> {
    path.map_or(Ok(Vec::new()), |path| {
        files::read_slot(path).with_context(|| format!("cannot read slot image {}", path.display()))
    })
}

/// The booted blob (or the safe state and why the blob did not boot), or a reference controller.
pub(crate) fn controller<'a>(
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
pub(crate) struct Outputs {
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
                let wall_change = args.faults.parse::<Faults>().ok().and_then(|f| f.wall);
                let plot = AtomicFile::create(p).and_then(|f| {
                    SvgWriter::start_with_faults(f, scenario, controller, wall_change)
                });
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

pub(crate) fn report_failures(report: &Report, blob: Option<&Path>) {
    if let Some(reason) = &report.boot_error {
        let from = blob
            .map(|p| format!("{}: ", p.display()))
            .unwrap_or_default();
        errln!("error: {from}{reason} (ran in the safe state: zero action)");
    } else if !report.pass.passed {
        errln!("FAIL: {}", report.pass.failures.join("; "));
    }
}
