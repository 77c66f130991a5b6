//! A plant that runs as a child process and speaks the plant link on its standard input and
//! output ([`super::messages`]): any program, in any language, is a [`crate::env::Env`].
//!
//! The host starts the command, asks for its hello and checks the boxes it declares; each
//! `reset` and `step` is then one request and one answer, each awaited for at most the step
//! timeout. A reader thread turns the plant's output into frames, so a plant that hangs is a
//! time-out, not a hung host. Whatever goes wrong (the program does not exist, exits, hangs,
//! writes garbage or a frame of another version, answers with the wrong sizes or with NaN) is
//! recorded as one [`Error::Plant`] line naming the plant, the request and what was expected;
//! from then on the plant ends every episode at once, and the loop that runs it reads the
//! error from [`Env::failure`] and stops.
//!
//! The child never outlives the host: it gets its own process group (a Ctrl-C at the terminal
//! reaches the host alone, which then finishes its episode, saves and closes the plant), its
//! standard input ends when the host exits however it exits, which the protocol makes the
//! plant's signal to leave, and where util-linux's `setpriv` is installed the kernel also kills
//! it when the host dies (`--pdeathsig`), for a plant that hangs without reading.

use std::io::{BufReader, Write};
use std::os::unix::process::CommandExt;
use std::process::{Child, ChildStdin, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant};

use super::messages::{self, Agent, FromPlant, Hello, LinkError, StepReply, ToPlant};
use crate::env::{BoxSpace, Env, Step, StepInfo};
use crate::Error;

/// The most observation values a plant may declare.
pub const MAX_OBSERVATIONS: usize = 4096;
/// The most action values a plant may declare.
pub const MAX_ACTIONS: usize = 256;

/// How long to wait for a plant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timeouts {
    /// For the hello after the start (interpreters and simulators take a while to load).
    pub start: Duration,
    /// For each reset and step.
    pub step: Duration,
}

impl Default for Timeouts {
    fn default() -> Self {
        Timeouts {
            start: Duration::from_secs(60),
            step: Duration::from_secs(10),
        }
    }
}

/// What the reader thread hands over.
enum Event {
    Frame(Result<Vec<u8>, LinkError>),
    /// The plant closed its output (it exited, or is about to).
    End,
    Io(String),
}

/// A plant process behind the [`Env`] interface.
#[derive(Debug)]
pub struct ChildPlant {
    command: String,
    child: Child,
    stdin: Option<ChildStdin>,
    frames: Receiver<EventBox>,
    hello: Hello,
    observation_space: BoxSpace,
    action_space: BoxSpace,
    timeouts: Timeouts,
    failure: Option<Error>,
    /// Steps since the last reset, and that reset's seed, for error messages.
    steps: u64,
    seed: Option<u64>,
}

/// [`Event`] in a box that is `Debug` (the receiver's type parameter must be).
struct EventBox(Event);

impl std::fmt::Debug for EventBox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Event")
    }
}

impl ChildPlant {
    /// Starts `command` (a program and its arguments, split as a shell would, quotes
    /// included), asks for its hello and checks it.
    ///
    /// ```
    /// use firmware_sim::plant_link::child::{ChildPlant, Timeouts};
    /// let e = ChildPlant::spawn("no-such-plant --fast", Timeouts::default()).unwrap_err();
    /// assert_eq!(
    ///     e.to_string(),
    ///     "plant \"no-such-plant --fast\": cannot start: no program no-such-plant on PATH"
    /// );
    /// ```
    pub fn spawn(command: &str, timeouts: Timeouts) -> Result<ChildPlant, Error> {
        let fail = |message: String| Error::Plant {
            plant: command.to_string(),
            message,
        };
        let argv = shlex::split(command)
            .filter(|argv| !argv.is_empty())
            .ok_or_else(|| {
                fail("cannot start: not a command (empty, or a quote left open)".into())
            })?;
        let program = crate::process::find_program(&argv[0])
            .map_err(|why| fail(format!("cannot start: {why}")))?;
        let mut child = crate::process::dying_with_us(&program, &argv[1..])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .process_group(0)
            .spawn()
            .map_err(|e| fail(format!("cannot start {}: {e}", program.display())))?;
        let (stdin, stdout) = (child.stdin.take(), child.stdout.take());
        let (sender, frames) = mpsc::channel();
        if let Some(stdout) = stdout {
            std::thread::spawn(move || {
                let mut input = BufReader::new(stdout);
                loop {
                    let event = match messages::read_frame(&mut input) {
                        Ok(Some(frame)) => Event::Frame(frame),
                        Ok(None) => Event::End,
                        Err(e) => Event::Io(e.to_string()),
                    };
                    let last = !matches!(event, Event::Frame(_));
                    if sender.send(EventBox(event)).is_err() || last {
                        return;
                    }
                }
            });
        }
        let mut plant = ChildPlant {
            command: command.to_string(),
            child,
            stdin,
            frames,
            hello: Hello {
                name: String::new(),
                agents: Vec::new(),
            },
            observation_space: empty_box(),
            action_space: empty_box(),
            timeouts,
            failure: None,
            steps: 0,
            seed: None,
        };
        let hello = match plant.request(&ToPlant::Hello, timeouts.start)? {
            FromPlant::Hello(hello) => hello,
            other => return Err(plant.error(format!("answered the hello with a {}", other.name()))),
        };
        let (observation_space, action_space) =
            check_hello(&hello).map_err(|why| plant.error(format!("its hello {why}")))?;
        plant.hello = hello;
        plant.observation_space = observation_space;
        plant.action_space = action_space;
        Ok(plant)
    }

    /// The plant's hello (its name and boxes), as it sent it.
    pub fn hello(&self) -> &Hello {
        &self.hello
    }

    /// The command it was started with.
    pub fn command(&self) -> &str {
        &self.command
    }

    /// The plant process's id (tests check with it that no plant outlives its `ChildPlant`).
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    fn error(&self, message: String) -> Error {
        Error::Plant {
            plant: self.command.clone(),
            message,
        }
    }

    /// Where in the run a request failed: "the step 12 after reset(seed 7)".
    fn at(&self, request: &ToPlant) -> String {
        match (request, self.seed) {
            (ToPlant::Step { .. }, Some(seed)) => {
                format!("step {} after reset(seed {seed})", self.steps + 1)
            }
            (ToPlant::Reset { seed }, _) => format!("reset(seed {seed})"),
            (other, _) => other.name().to_string(),
        }
    }

    /// Sends one request and waits for its answer.
    fn request(&mut self, request: &ToPlant, timeout: Duration) -> Result<FromPlant, Error> {
        let at = self.at(request);
        let frame = messages::encode(request).map_err(|e| self.error(format!("{at}: {e}")))?;
        let sent = match self.stdin.as_mut() {
            Some(stdin) => stdin.write_all(&frame).and_then(|()| stdin.flush()),
            None => Err(std::io::ErrorKind::BrokenPipe.into()),
        };
        if sent.is_err() {
            let why = self.exit_reason(timeout);
            return Err(self.error(format!("{at}: {why} before the request could be sent")));
        }
        let event = match self.frames.recv_timeout(timeout) {
            Ok(EventBox(event)) => event,
            Err(RecvTimeoutError::Timeout) => {
                let which = if matches!(request, ToPlant::Hello) {
                    "start"
                } else {
                    "step"
                };
                return Err(self.error(format!(
                    "{at}: no answer within {} (the {which} timeout; the plant hangs or is too slow)",
                    seconds(timeout)
                )));
            }
            Err(RecvTimeoutError::Disconnected) => Event::End,
        };
        let frame = match event {
            Event::Frame(frame) => frame,
            Event::End => {
                let why = self.exit_reason(timeout);
                return Err(self.error(format!("{at}: {why} before answering")));
            }
            Event::Io(e) => return Err(self.error(format!("{at}: cannot read its output: {e}"))),
        };
        let answer = frame
            .and_then(|mut bytes| messages::decode::<FromPlant>(&mut bytes))
            .map_err(|e| {
                self.error(format!(
                    "{at}: sent {e}, expected a {} answer",
                    request.name()
                ))
            })?;
        match answer {
            FromPlant::Error { message } => {
                Err(self.error(format!("{at}: the plant says: {message}")))
            }
            answer => Ok(answer),
        }
    }

    /// Why the plant stopped talking: its exit status if it exited within `wait`.
    fn exit_reason(&mut self, wait: Duration) -> String {
        let until = Instant::now() + wait.min(Duration::from_secs(2));
        loop {
            match self.child.try_wait() {
                Ok(Some(status)) => return exited(status),
                Ok(None) if Instant::now() < until => std::thread::sleep(Duration::from_millis(5)),
                _ => return "it closed its output".to_string(),
            }
        }
    }

    /// Records the first failure; the plant then ends every episode at once.
    fn fail(&mut self, e: Error) {
        if self.failure.is_none() {
            self.failure = Some(e);
        }
    }

    fn ended_step(&self) -> Step {
        Step {
            observation: vec![0.0; self.observation_space.dim()],
            reward: 0.0,
            terminated: true,
            truncated: false,
            info: StepInfo {
                applied: vec![0.0; self.action_space.dim()],
                margin_touched: false,
                success: None,
            },
        }
    }

    fn checked_observation(&self, what: &str, observation: Vec<f32>) -> Result<Vec<f32>, String> {
        check_values(what, &observation, self.observation_space.dim())?;
        Ok(observation)
    }

    fn checked_step(&self, action: &[f32], reply: StepReply) -> Result<Step, String> {
        let observation = self.checked_observation("observation", reply.observation)?;
        if !reply.reward.is_finite() {
            return Err(format!(
                "a reward of {}, expected a finite number",
                reply.reward
            ));
        }
        let applied = if reply.applied.is_empty() {
            action.to_vec()
        } else {
            check_values("applied motion", &reply.applied, self.action_space.dim())?;
            reply.applied
        };
        Ok(Step {
            observation,
            reward: reply.reward,
            terminated: reply.terminated,
            truncated: reply.truncated,
            info: StepInfo {
                applied,
                margin_touched: reply.margin_touched,
                success: reply.success,
            },
        })
    }
}

impl Env for ChildPlant {
    fn observation_space(&self) -> &BoxSpace {
        &self.observation_space
    }

    fn action_space(&self) -> &BoxSpace {
        &self.action_space
    }

    fn reset(&mut self, seed: u64) -> Vec<f32> {
        if self.failure.is_some() {
            return vec![0.0; self.observation_space.dim()];
        }
        let request = ToPlant::Reset { seed };
        let at = self.at(&request);
        (self.seed, self.steps) = (Some(seed), 0);
        let answer = self
            .request(&request, self.timeouts.step)
            .and_then(|answer| match answer {
                FromPlant::Reset { observation } => self
                    .checked_observation("observation", observation)
                    .map_err(|why| self.error(format!("{at}: {why}"))),
                other => Err(self.error(format!(
                    "{at}: answered with a {}, expected a reset",
                    other.name()
                ))),
            });
        answer.unwrap_or_else(|e| {
            self.fail(e);
            vec![0.0; self.observation_space.dim()]
        })
    }

    fn step(&mut self, action: &[f32]) -> Step {
        if self.failure.is_some() {
            return self.ended_step();
        }
        // The Env contract: non-finite components are 0; the plant only ever sees numbers.
        let action: Vec<f32> = action
            .iter()
            .map(|&a| if a.is_finite() { a } else { 0.0 })
            .collect();
        let request = ToPlant::Step { action };
        let at = self.at(&request);
        let ToPlant::Step { action } = &request else {
            unreachable!("built above")
        };
        let answer = self
            .request(&request, self.timeouts.step)
            .and_then(|answer| match answer {
                FromPlant::Step(reply) => self
                    .checked_step(action, reply)
                    .map_err(|why| self.error(format!("{at}: {why}"))),
                other => Err(self.error(format!(
                    "{at}: answered with a {}, expected a step",
                    other.name()
                ))),
            });
        self.steps += 1;
        answer.unwrap_or_else(|e| {
            self.fail(e);
            self.ended_step()
        })
    }

    fn failure(&self) -> Option<Error> {
        self.failure.clone()
    }
}

impl Drop for ChildPlant {
    /// Asks the plant to close, gives it a moment, then kills it: no child is left behind.
    fn drop(&mut self) {
        if let Some(mut stdin) = self.stdin.take() {
            if let Ok(frame) = messages::encode(&ToPlant::Close) {
                let _ = stdin.write_all(&frame).and_then(|()| stdin.flush());
            }
            // Dropping stdin ends the plant's input: its other signal to leave.
        }
        let until = Instant::now() + Duration::from_secs(1);
        while Instant::now() < until {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Checks a hello; the boxes it declares, or what is wrong with them.
pub fn check_hello(hello: &Hello) -> Result<(BoxSpace, BoxSpace), String> {
    let [agent] = hello.agents.as_slice() else {
        return Err(format!(
            "declares {} agents; this version of the plant link runs plants of exactly one",
            hello.agents.len()
        ));
    };
    let Agent {
        observation_low,
        observation_high,
        action_low,
        action_high,
        ..
    } = agent;
    check_box(
        "observation",
        observation_low,
        observation_high,
        MAX_OBSERVATIONS,
        false,
    )?;
    check_box("action", action_low, action_high, MAX_ACTIONS, true)?;
    let space = |low: &Vec<f32>, high: &Vec<f32>| BoxSpace {
        low: low.clone(),
        high: high.clone(),
    };
    Ok((
        space(observation_low, observation_high),
        space(action_low, action_high),
    ))
}

/// A box: as many lows as highs, 1..=`max` of them, none NaN, low below high (or equal, for
/// observations), finite where `finite` (actions: the actor's outputs map onto the box).
fn check_box(
    what: &str,
    low: &[f32],
    high: &[f32],
    max: usize,
    finite: bool,
) -> Result<(), String> {
    if low.len() != high.len() {
        return Err(format!(
            "declares an {what} box of {} lows and {} highs",
            low.len(),
            high.len()
        ));
    }
    if !(1..=max).contains(&low.len()) {
        return Err(format!(
            "declares an {what} box of {} dimensions, expected 1 to {max}",
            low.len()
        ));
    }
    for (i, (&l, &h)) in low.iter().zip(high).enumerate() {
        let bad = if l.is_nan() || h.is_nan() {
            Some("NaN")
        } else if finite && !(l.is_finite() && h.is_finite()) {
            Some("infinite (an action box must be finite)")
        } else if l > h || (finite && l == h) {
            Some(if l > h { "inverted" } else { "empty" })
        } else {
            None
        };
        if let Some(why) = bad {
            return Err(format!(
                "declares an {what} box whose dimension {i} is {why}: [{l}, {h}]"
            ));
        }
    }
    Ok(())
}

/// Values of the declared size, every one finite.
fn check_values(what: &str, values: &[f32], expected: usize) -> Result<(), String> {
    if values.len() != expected {
        return Err(format!(
            "an {what} of {} values, expected {expected} (the hello's box)",
            values.len()
        ));
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(format!(
            "an {what} whose value {i} is {}, expected a finite number",
            values[i]
        )),
        None => Ok(()),
    }
}

fn exited(status: ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (status.code(), status.signal()) {
        (Some(code), _) => format!("it exited with status {code}"),
        (None, Some(signal)) => format!("it was killed by signal {signal}"),
        _ => "it exited".to_string(),
    }
}

fn seconds(d: Duration) -> String {
    format!("{} s", d.as_secs_f64())
}

fn empty_box() -> BoxSpace {
    BoxSpace {
        low: Vec::new(),
        high: Vec::new(),
    }
}
