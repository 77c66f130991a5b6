//! The chip as a [`Controller`]: each `act` sends the observation in a frame and waits for the
//! chip's action. A chip that fails (silent past the tick timeout, a garbled or foreign-version
//! frame, a new hello: it reset, a closed link, Ctrl-C) latches its first failure, answers the
//! rest of the episode with the safe action without touching the link, and
//! [`failure`](Controller::failure) hands the failure to the test protocol, which stops.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use hil_protocol::{
    decode, encode, FromChip, Hello, Receiver, Running, SlotState, ToChip, Values, MAX_FRAME,
};
use serde::{Deserialize, Serialize};

use super::link::Link;
use crate::controller::Controller;
use crate::Error;

/// How often a wait for the chip looks at the Ctrl-C flag.
const POLL: Duration = Duration::from_millis(100);

/// Something that owns the chip's other end (QEMU's process): asked why the link closed, and
/// dropped (QEMU killed) with the chip.
pub trait Backend: Send {
    /// Why the chip went away, if it knows (QEMU's exit status and last output line), waiting
    /// up to `grace` for it to go (a closed link usually means it is going).
    fn exit_note(&mut self, grace: Duration) -> Option<String>;
    /// The chip said its hello: it has booted, so whatever it read at boot has been read
    /// (QEMU's slot images), and what was kept for that can go.
    fn booted(&mut self) {}
}

/// The chip in the loop (see the module docs).
pub struct HilChip {
    name: String,
    link_name: String,
    observations: usize,
    actions: usize,
    link: Box<dyn Link>,
    backend: Option<Box<dyn Backend>>,
    rx: Receiver,
    inbuf: Vec<u8>,
    inpos: usize,
    hello: Hello,
    timeout: Duration,
    interrupt: Option<Arc<AtomicBool>>,
    tick: u32,
    failure: Option<Error>,
    stats: Stats,
    budget: Option<u64>,
}

impl std::fmt::Debug for HilChip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("HilChip")
            .field("link", &self.link_name)
            .field("hello", &self.hello)
            .finish_non_exhaustive()
    }
}

#[derive(Debug, Default)]
struct Stats {
    ticks: u64,
    instructions_sum: u64,
    instructions_max: u64,
    over_budget: u64,
}

/// The chip's side of a run, for the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ChipReport {
    /// The link: `qemu-m4f`, `qemu-m3` or `serial:PATH`.
    pub link: String,
    /// The slot that ran (`A`, `B`), or `safe` (no slot verified).
    pub slot: String,
    /// What became of each slot at the chip's boot.
    pub boot: String,
    /// The running slot's sequence number.
    pub sequence: Option<u32>,
    /// The running blob's CRC-32, hex.
    pub blob_crc: Option<String>,
    /// The running blob's shape and encoding, e.g. `4x48 f32`.
    pub blob: Option<String>,
    /// Ticks the chip computed.
    pub ticks: u64,
    /// Mean instructions per tick (`act` alone; SysTick under QEMU's -icount, to 40
    /// instructions; on a board, core cycles scaled by the boot calibration).
    pub instructions_mean: f64,
    /// The most instructions one tick took.
    pub instructions_max: u64,
    /// `--tick-budget`, if given.
    pub tick_budget: Option<u64>,
    /// Ticks over the budget.
    pub ticks_over_budget: u64,
}

impl ChipReport {
    /// The summary table's rows for the chip.
    pub fn rows(&self) -> Vec<(&'static str, String)> {
        let running = match (&self.sequence, &self.blob_crc, &self.blob) {
            (Some(seq), Some(crc), Some(blob)) => {
                format!("slot {}, sequence {seq}, blob CRC {crc}, {blob}", self.slot)
            }
            _ => "safe state (no slot runs)".to_string(),
        };
        let mut rows = vec![
            ("chip", format!("{}: {running}", self.link)),
            ("chip boot", self.boot.clone()),
            (
                "instructions per tick mean / max",
                format!(
                    "{:.0} / {} ({} ticks on the chip)",
                    self.instructions_mean, self.instructions_max, self.ticks
                ),
            ),
        ];
        if let Some(budget) = self.tick_budget {
            rows.push((
                "tick budget",
                format!(
                    "{budget} instructions: {} ticks over",
                    self.ticks_over_budget
                ),
            ));
        }
        rows
    }
}

/// The hello's account of the two slots, one line.
pub fn describe_boot(hello: &Hello) -> String {
    let state = |s: &SlotState| match s {
        SlotState::Running { sequence } => format!("running (sequence {sequence})"),
        SlotState::Standby { sequence } => format!("standby (sequence {sequence})"),
        SlotState::Failed { reason } => format!("failed: {reason}"),
    };
    format!("slot A {}; slot B {}", state(&hello.a), state(&hello.b))
}

/// The running blob's shape and encoding, e.g. `4x48 f32`.
fn describe_blob(r: &Running) -> String {
    let encoding = match r.encoding {
        hil_protocol::Encoding::F32 => "f32",
        hil_protocol::Encoding::F16 => "f16",
        hil_protocol::Encoding::Int8 => "int8",
        hil_protocol::Encoding::Integer => "integer",
    };
    format!("{}x{} {encoding}", r.depth, r.width)
}

/// How a chip is reached and judged.
#[derive(Debug, Clone)]
pub struct ChipOptions {
    /// For reports and errors: `qemu-m4f`, `serial:/dev/ttyACM0`.
    pub link_name: String,
    /// The longest wait for a frame (the hello, or one tick's action).
    pub timeout: Duration,
    /// Ask for the hello (a board booted long ago) rather than wait for the boot hello (QEMU);
    /// undecodable bytes before it are line noise and skipped.
    pub ask_hello: bool,
    /// Ctrl-C: when set, the chip stops at the next tick.
    pub interrupt: Option<Arc<AtomicBool>>,
    /// Instructions one tick may take (`--tick-budget`).
    pub budget: Option<u64>,
}

impl HilChip {
    /// Connects: waits for the chip's hello (asking for it if `options.ask_hello`). `name`,
    /// `observations` and `actions` are the host's boot of the same slots (the report must read
    /// as the host loop's); the caller checks the hello against it.
    pub fn connect(
        link: Box<dyn Link>,
        backend: Option<Box<dyn Backend>>,
        options: ChipOptions,
        name: String,
        observations: usize,
        actions: usize,
    ) -> Result<HilChip, Error> {
        let mut chip = HilChip {
            name,
            link_name: options.link_name,
            observations,
            actions,
            link,
            backend,
            rx: Receiver::new(),
            inbuf: vec![0; 4096],
            inpos: 0,
            hello: Hello {
                running: None,
                a: SlotState::Running { sequence: 0 },
                b: SlotState::Running { sequence: 0 },
                calibration: hil_protocol::Calibration {
                    instructions: 0,
                    ticks: 0,
                },
            },
            timeout: options.timeout,
            interrupt: options.interrupt,
            tick: 0,
            failure: None,
            stats: Stats::default(),
            budget: options.budget,
        };
        chip.inbuf.truncate(0);
        if options.ask_hello {
            chip.send(&ToChip::Hello)?;
        }
        // One deadline for the whole wait: what comes before the hello does not restart it.
        let deadline = Instant::now() + chip.timeout;
        let mut before = BeforeHello::default();
        loop {
            match chip.receive(deadline) {
                Ok(FromChip::Hello(hello)) => {
                    chip.hello = hello;
                    if let Some(backend) = chip.backend.as_mut() {
                        backend.booted();
                    }
                    return Ok(chip);
                }
                // A board's line may carry noise (or answers to an earlier host) before it.
                Ok(other) if options.ask_hello => before.messages.push(what(&other)),
                Err(Frame::Bad(hil_protocol::Error::Version { found })) if options.ask_hello => {
                    before.versions.push(found)
                }
                Err(Frame::Bad(_)) if options.ask_hello => before.bad += 1,
                Ok(other) => {
                    return Err(
                        chip.fail(format!("the chip sent {} before its hello", what(&other)))
                    )
                }
                Err(Frame::Silent) if !before.is_empty() => {
                    let text = format!(
                        "no hello within {:.1} s: received {}",
                        chip.timeout.as_secs_f64(),
                        before.describe()
                    );
                    return Err(chip.fail(text));
                }
                Err(e) => return Err(chip.frame_error(e, "the hello")),
            }
        }
    }

    /// The chip's hello: what it booted.
    pub fn hello(&self) -> &Hello {
        &self.hello
    }

    /// The chip's side of the run so far.
    pub fn report(&self) -> ChipReport {
        let running = self.hello.running.as_ref();
        let slot = match running.map(|r| r.slot) {
            Some(hil_protocol::Slot::A) => "A",
            Some(hil_protocol::Slot::B) => "B",
            None => "safe",
        };
        ChipReport {
            link: self.link_name.clone(),
            slot: slot.to_string(),
            boot: describe_boot(&self.hello),
            sequence: running.map(|r| r.sequence),
            blob_crc: running.map(|r| format!("{:#010x}", r.blob_crc)),
            blob: running.map(describe_blob),
            ticks: self.stats.ticks,
            instructions_mean: self.stats.instructions_sum as f64 / self.stats.ticks.max(1) as f64,
            instructions_max: self.stats.instructions_max,
            tick_budget: self.budget,
            ticks_over_budget: self.stats.over_budget,
        }
    }

    fn send(&mut self, message: &ToChip) -> Result<(), Error> {
        let mut buf = [0u8; MAX_FRAME];
        let frame = encode(message, &mut buf)
            .map_err(|e| Error::Hil(format!("cannot encode a frame for the chip: {e}")))?;
        if let Err(e) = self.link.send(frame) {
            return Err(self.fail(format!("cannot send to the chip: {e}")));
        }
        Ok(())
    }

    /// The next frame from the chip, before `deadline`.
    fn receive(&mut self, deadline: Instant) -> Result<FromChip, Frame> {
        loop {
            while self.inpos < self.inbuf.len() {
                let byte = self.inbuf[self.inpos];
                self.inpos += 1;
                if let Some(frame) = self.rx.push(byte) {
                    return frame.and_then(decode::<FromChip>).map_err(Frame::Bad);
                }
            }
            if self
                .interrupt
                .as_ref()
                .is_some_and(|f| f.load(Ordering::SeqCst))
            {
                return Err(Frame::Interrupted);
            }
            let now = Instant::now();
            if now >= deadline {
                return Err(Frame::Silent);
            }
            self.inbuf.resize(4096, 0);
            self.inpos = 0;
            let wait = (deadline - now).min(POLL);
            match self.link.receive(&mut self.inbuf, wait) {
                Ok(n) => self.inbuf.truncate(n),
                Err(e) => {
                    self.inbuf.truncate(0);
                    return Err(Frame::Closed(e.to_string()));
                }
            }
        }
    }

    /// A one-line error for a frame that did not come, with QEMU's account where there is one.
    fn frame_error(&mut self, e: Frame, waiting_for: &str) -> Error {
        let text = match e {
            Frame::Silent => format!(
                "the chip sent nothing for {:.1} s, waiting for {waiting_for}: it hangs, or the link is down",
                self.timeout.as_secs_f64()
            ),
            Frame::Bad(hil_protocol::Error::Version { found }) => format!(
                "the chip sent a frame of protocol version {found}, waiting for {waiting_for}; firmware-sim speaks version {}: flash a HIL firmware of this version",
                hil_protocol::VERSION
            ),
            Frame::Bad(e) => format!("the chip sent {e}, waiting for {waiting_for}"),
            Frame::Closed(e) => {
                let text = format!("the link to the chip closed, waiting for {waiting_for} ({e})");
                return self.fail_after(text, Duration::from_secs(1));
            }
            Frame::Interrupted => format!("interrupted (Ctrl-C), waiting for {waiting_for}"),
        };
        self.fail(text)
    }

    fn fail(&mut self, text: String) -> Error {
        self.fail_after(text, Duration::ZERO)
    }

    /// [`fail`](Self::fail), giving the backend `grace` to explain.
    fn fail_after(&mut self, text: String, grace: Duration) -> Error {
        let note = self.backend.as_mut().and_then(|b| b.exit_note(grace));
        let text = match note {
            Some(note) => format!("{text}; {note}"),
            None => text,
        };
        Error::Hil(format!("{}: {text}", self.link_name))
    }

    /// Whether `values` answer an action of `n` values: the chip's action has the plant's size
    /// (the blob's, which boot matched to the plant); a chip in the safe state has no blob and
    /// so no action size, and answers an empty action, the zero action here.
    fn answers(&self, values: &[f32], n: usize) -> bool {
        values.len() == n || (values.is_empty() && self.hello.running.is_none())
    }

    /// One tick on the chip; `Err` latches.
    fn tick(&mut self, obs: &[f32], action: &mut [f32]) -> Result<(), Error> {
        let tick = self.tick;
        self.tick = self.tick.wrapping_add(1);
        let observation = Values::from_slice(obs).map_err(|_| {
            Error::Hil(format!(
                "an observation of {} values: the protocol carries at most {}",
                obs.len(),
                hil_protocol::MAX_VALUES
            ))
        })?;
        self.send(&ToChip::Observe { tick, observation })?;
        let waiting_for = format!("the action of tick {tick}");
        let deadline = Instant::now() + self.timeout;
        let mut message = self.receive(deadline);
        // A board that boots as its port opens sends its boot hello and then answers the
        // host's request with another: before the first action, a hello is that boot, not a
        // reset.
        while let (Ok(FromChip::Hello(hello)), 0) = (&message, self.stats.ticks) {
            if *hello != self.hello {
                let (first, then) = (describe_boot(&self.hello), describe_boot(hello));
                return Err(self.fail(format!(
                    "the chip sent a second hello before its first action, naming another boot (first: {first}; then: {then}): it reset, or the port held an old boot's hello"
                )));
            }
            message = self.receive(deadline);
        }
        match message {
            Ok(FromChip::Action {
                tick: t,
                action: a,
                ticks,
            }) if t == tick && self.answers(&a, action.len()) => {
                if a.is_empty() {
                    action.fill(0.0);
                } else {
                    action.copy_from_slice(&a);
                }
                let instructions = self.hello.calibration.instructions(ticks);
                self.stats.ticks += 1;
                self.stats.instructions_sum += instructions;
                self.stats.instructions_max = self.stats.instructions_max.max(instructions);
                if self.budget.is_some_and(|b| instructions > b) {
                    self.stats.over_budget += 1;
                }
                Ok(())
            }
            Ok(FromChip::Action {
                tick: t, action: a, ..
            }) => Err(self.fail(format!(
                "the chip answered tick {tick} with tick {t} ({} values for {})",
                a.len(),
                action.len()
            ))),
            Ok(FromChip::Hello(hello)) => {
                let boot = describe_boot(&hello);
                Err(self.fail(format!(
                    "the chip reset mid-episode (a new hello at tick {tick}: {boot})"
                )))
            }
            Ok(FromChip::Refused { reason, .. }) => {
                Err(self.fail(format!("the chip refused tick {tick}: {reason}")))
            }
            Err(e) => Err(self.frame_error(e, &waiting_for)),
        }
    }
}

/// What came on a serial line before the hello.
#[derive(Default)]
struct BeforeHello {
    /// Frames that did not decode (noise, a cut frame).
    bad: usize,
    /// The versions of frames of another protocol version.
    versions: Vec<u16>,
    /// Messages other than a hello.
    messages: Vec<&'static str>,
}

impl BeforeHello {
    fn is_empty(&self) -> bool {
        self.bad == 0 && self.versions.is_empty() && self.messages.is_empty()
    }

    /// `14 bad frames, 1 other message (an action) and 1 frame of protocol version 2 ...`.
    fn describe(&self) -> String {
        let plural =
            |n: usize, one: &str, many: &str| format!("{n} {}", if n == 1 { one } else { many });
        let mut parts = Vec::new();
        if self.bad > 0 {
            parts.push(plural(self.bad, "bad frame", "bad frames"));
        }
        if !self.messages.is_empty() {
            let mut kinds = self.messages.clone();
            kinds.sort_unstable();
            kinds.dedup();
            parts.push(format!(
                "{} ({})",
                plural(
                    self.messages.len(),
                    "message other than a hello",
                    "messages other than a hello"
                ),
                kinds.join(", ")
            ));
        }
        if !self.versions.is_empty() {
            let mut versions = self.versions.clone();
            versions.sort_unstable();
            versions.dedup();
            let versions: Vec<String> = versions.iter().map(u16::to_string).collect();
            parts.push(format!(
                "{} of protocol version {} (firmware-sim speaks version {}: flash a HIL firmware of this version)",
                plural(self.versions.len(), "frame", "frames"),
                versions.join(", "),
                hil_protocol::VERSION
            ));
        }
        match parts.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => format!("{} and {last}", rest.join(", ")),
            None => "nothing".to_string(),
        }
    }
}

/// Why no message came.
enum Frame {
    Silent,
    Bad(hil_protocol::Error),
    Closed(String),
    Interrupted,
}

fn what(m: &FromChip) -> &'static str {
    match m {
        FromChip::Hello(_) => "a hello",
        FromChip::Action { .. } => "an action",
        FromChip::Refused { .. } => "a refusal",
    }
}

impl Controller for HilChip {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn observations(&self) -> usize {
        self.observations
    }
    fn actions(&self) -> usize {
        self.actions
    }
    fn act(&mut self, obs: &[f32], action: &mut [f32]) {
        if self.failure.is_some() {
            action.fill(0.0);
            return;
        }
        if let Err(e) = self.tick(obs, action) {
            self.failure = Some(e);
            action.fill(0.0);
        }
    }
    fn failure(&mut self) -> Option<Error> {
        self.failure.clone()
    }
}
