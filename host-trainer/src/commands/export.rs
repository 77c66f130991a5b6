//! `host-trainer export`: a run's blobs in any weight encoding, and flash slot images.

use firmware_sim::plant_link::child::Timeouts;
use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use firmware_sim::outln;
use host_trainer::blob::export::{self, ImageFormat, SlotTarget};
use host_trainer::run::folder::{self, RunDir};
use host_trainer::run::lock;
use host_trainer::run::plant::RunPlant;
use host_trainer::run::race::RaceRecord;
use policy_core::slot::SlotId;
use policy_core::Encoding;

use super::train::resume;

#[derive(Debug, Args)]
pub(crate) struct ExportArgs {
    /// The run folder holding checkpoint.postcard, or a race's folder (its winner is exported
    /// into it).
    #[arg(long)]
    run: PathBuf,
    /// Export the last networks instead of the policy validation kept (the best by
    /// validation; a run without validation keeps its last networks anyway).
    #[arg(long)]
    last: bool,
    /// How the policy's weights are stored: f32 (policy.postcard and the critic), f16 or int8
    /// (policy-f16.postcard, policy-int8.postcard; weights only, everything else stays f32),
    /// or integer (policy-integer.postcard: integer arithmetic throughout, calibrated on the
    /// observations the policy meets in --calibration-episodes test episodes; actors only).
    #[arg(long, default_value = "f32", value_parser = parse_encoding)]
    encoding: Encoding,
    /// Episodes of firmware-sim's test protocol (with their own seed) whose observations
    /// calibrate the integer encoding's activation ranges.
    #[arg(
        long,
        default_value_t = export::CALIBRATION_EPISODES,
        value_parser = clap::value_parser!(u64).range(1..=10_000)
    )]
    calibration_episodes: u64,
    /// Also write a flash slot image of the policy (a slot record: header with --sequence, then
    /// the blob): bin (raw; the flasher is given the address) or hex (Intel HEX at the address).
    #[arg(long, value_enum, requires_all = ["slot", "sequence"])]
    image: Option<ImageFormat>,
    /// The slot the image is for: a or b (write the one the device is not running).
    #[arg(long, value_parser = parse_slot, requires = "image")]
    slot: Option<SlotId>,
    /// The record's sequence number: one more than the running slot's, which the firmware
    /// prints at boot (`SLOT A running 3`). The newer slot that verifies runs.
    #[arg(long, requires = "image")]
    sequence: Option<u32>,
    /// The slot's flash address, decimal or 0x hex [default: the example firmware's
    /// (firmware/mps2/memory.x): 0x40000 for a, 0x60000 for b].
    #[arg(long, value_parser = parse_address, requires = "image")]
    address: Option<u32>,
    /// The slot's size in bytes; a record that does not fit is refused [default: 131072, the
    /// example firmware's].
    #[arg(long, requires = "image")]
    slot_size: Option<usize>,
}

pub(crate) fn parse_slot(s: &str) -> Result<SlotId, String> {
    match s {
        "a" | "A" => Ok(SlotId::A),
        "b" | "B" => Ok(SlotId::B),
        _ => Err(format!("expected a or b, found {s:?}")),
    }
}

pub(crate) fn parse_address(s: &str) -> Result<u32, String> {
    let parsed = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(hex) => u32::from_str_radix(&hex.replace('_', ""), 16),
        None => s.parse(),
    };
    parsed.map_err(|_| format!("expected a 32-bit address such as 0x08040000, found {s:?}"))
}

pub(crate) fn parse_encoding(s: &str) -> Result<Encoding, String> {
    Encoding::ALL
        .into_iter()
        .find(|e| e.to_string() == s)
        .ok_or_else(|| format!("expected f32, f16, int8 or integer, found {s:?}"))
}

pub(crate) fn export_command(args: ExportArgs) -> Result<()> {
    // A race's folder holds its winner's blobs; the winner's networks are in its racer folder.
    let (source, target, _race_lock) = match race_winner(&args.run)? {
        Some(winner) => {
            let race = RunDir::open(&args.run)?;
            let lock = lock::acquire(race.path())?;
            (winner, Some(race), Some(lock))
        }
        None => (args.run.clone(), None, None),
    };
    // Without a checkpoint there is no trained policy: exporting the recorded config's freshly
    // initialised networks would write an untrained policy under the run's name.
    let run = RunDir::open(&source)?;
    if !run.file(folder::CHECKPOINT).exists() {
        anyhow::bail!(
            "{} has no checkpoint: nothing to export (train it, or continue it with train --resume {})",
            run.path().display(),
            run.path().display()
        );
    }
    // (A run on a plant process starts its plant again here: the checkpoint's networks are
    // checked against the plant's hello before anything is exported.)
    let (trainer, run, _lock) = resume(&source, None, Timeouts::default())?;
    let out = target.as_ref().unwrap_or(&run);
    let name = folder::policy_file(args.encoding);
    let (f32, critic) = if args.last {
        trainer.last_blobs()?
    } else {
        trainer.kept_blobs()?
    };
    let which = match (&trainer.kept, args.last) {
        (Some(kept), false) => {
            format!("the policy validation kept, episode {}", kept.round.episode)
        }
        _ => format!("the last networks, episode {}", trainer.episode),
    };
    let mut calibrated = String::new();
    let policy = match args.encoding {
        Encoding::F32 => f32,
        Encoding::Integer => {
            let scenario = match &trainer.plant {
                RunPlant::Scenario(scenario) => scenario,
                other => anyhow::bail!(
                    "the integer encoding is calibrated on firmware-sim's test protocol, which \
                     runs scenarios; this run's plant is {}",
                    other.name()
                ),
            };
            let header = policy_core::blob::verify(&f32)?.header;
            let kind = header.kind;
            if kind != policy_core::ModelKind::Actor {
                anyhow::bail!(
                    "the integer encoding holds actors only; this run's policy is a {kind}"
                );
            }
            let episodes = args.calibration_episodes as usize;
            let observations = export::calibration_observations(&f32, scenario, episodes)?;
            let size = usize::from(header.shape.observations).max(1);
            calibrated = format!(
                ", calibrated on {} observations from {episodes} test episodes",
                observations.len() / size
            );
            export::encode_integer(&f32, &observations)?
        }
        other => export::encode(&f32, other)?,
    };
    // The image is made (and refused) before anything is written.
    let image = args
        .image
        .map(|format| slot_image(&args, format, &policy))
        .transpose()?;
    if args.encoding != Encoding::F32 {
        out.write(&name, &policy)?;
        outln!(
            "wrote {} ({} bytes, {} weights{calibrated}; {which})",
            out.file(&name).display(),
            policy.len(),
            args.encoding,
        );
    } else {
        out.write(folder::POLICY, &policy)?;
        let critic = match critic {
            Some(critic) => {
                out.write(folder::CRITIC, &critic)?;
                format!(" and {}", out.file(folder::CRITIC).display())
            }
            None => String::new(),
        };
        outln!(
            "wrote {}{critic} ({which})",
            out.file(folder::POLICY).display(),
        );
    }
    if let Some((format, id, target, bytes)) = image {
        write_slot_image(out, args.encoding, format, id, target, &bytes)?;
    }
    Ok(())
}

/// The winner's run folder of the race in `dir`, if `dir` is a race's folder; an error if the
/// race has no winner yet.
fn race_winner(dir: &std::path::Path) -> Result<Option<PathBuf>> {
    let path = dir.join(folder::RACE);
    if !path.is_file() {
        return Ok(None);
    }
    let record = RaceRecord::read(dir)?;
    let Some(winner) = record.winner_record() else {
        anyhow::bail!(
            "{} has no winner yet: continue the race with train --resume {}",
            dir.display(),
            dir.display()
        );
    };
    Ok(Some(
        winner
            .folder_in(dir)
            .with_context(|| format!("{}", path.display()))?,
    ))
}

pub(crate) fn slot_image(
    args: &ExportArgs,
    format: ImageFormat,
    policy: &[u8],
) -> Result<(ImageFormat, SlotId, SlotTarget, Vec<u8>)> {
    use policy_core::slot;
    // clap's `requires` guarantees both with --image.
    let (Some(id), Some(sequence)) = (args.slot, args.sequence) else {
        anyhow::bail!("--image needs --slot and --sequence");
    };
    let default_address = match id {
        SlotId::A => slot::EXAMPLE_SLOT_A,
        SlotId::B => slot::EXAMPLE_SLOT_B,
    };
    let target = SlotTarget {
        address: args.address.unwrap_or(default_address),
        size: args.slot_size.unwrap_or(slot::EXAMPLE_SLOT_SIZE),
        sequence,
    };
    let bytes = export::slot_image(policy, format, target)
        .with_context(|| format!("cannot make the slot {id} image"))?;
    Ok((format, id, target, bytes))
}

/// Writes the policy's flash slot image next to it and says how to flash it.
pub(crate) fn write_slot_image(
    run: &RunDir,
    encoding: Encoding,
    format: ImageFormat,
    id: SlotId,
    target: SlotTarget,
    bytes: &[u8],
) -> Result<()> {
    let name = folder::image_file(encoding, id, format);
    run.write(&name, bytes)?;
    let file = run.file(&name);
    let (path, address, sequence) = (file.display(), target.address, target.sequence);
    outln!("wrote {path} (slot {id} at {address:#010x}, sequence {sequence})");
    match format {
        ImageFormat::Bin => outln!(
            "flash it: probe-rs download --chip YOUR_CHIP --binary-format bin --base-address {address:#010x} {path}\n\
             under QEMU: -device loader,file={path},addr={address:#x}"
        ),
        ImageFormat::Hex => outln!(
            "flash it: probe-rs download --chip YOUR_CHIP --binary-format hex {path}\n\
             under QEMU: -device loader,file={path}"
        ),
    }
    Ok(())
}
