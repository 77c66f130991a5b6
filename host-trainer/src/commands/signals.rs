//! Ctrl-C (SIGINT), SIGTERM, SIGHUP, and a parent that goes: how every command stops at a
//! checkpoint, and the exit code it stops with. Each is named in what the command says: a run
//! stopped by a job scheduler's SIGTERM or a closed terminal's SIGHUP was once reported as a
//! Ctrl-C nobody pressed.

use std::io::Read as _;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The exit code after Ctrl-C (128 + SIGINT), as shells report it.
pub(crate) const INTERRUPTED: u8 = 130;

/// Ctrl-C presses so far: the first stops training after the current episode with a
/// checkpoint, the second exits at once.
pub(crate) static INTERRUPTS: AtomicU32 = AtomicU32::new(0);

/// When the first Ctrl-C came. A second delivery within [`SAME_PRESS`] is the same press: a
/// sweep's children get a terminal's Ctrl-C directly (they share its process group) and once
/// more from the sweep, which forwards it for the case where only the sweep got the signal.
static FIRST_PRESS: OnceLock<Instant> = OnceLock::new();
const SAME_PRESS: Duration = Duration::from_millis(500);

pub(crate) fn install_ctrl_c_handler() {
    set_ctrl_c_handler(|signal| {
        let first = *FIRST_PRESS.get_or_init(Instant::now);
        if INTERRUPTS.fetch_add(1, Ordering::SeqCst) == 0 {
            eprintln!(
                "\nhost-trainer: {}: stopping after this episode and writing a checkpoint ({} to exit at once)",
                signal.name,
                signal.again
            );
        } else if first.elapsed() >= SAME_PRESS {
            eprintln!(
                "\nhost-trainer: {}: interrupted; the last checkpoint is kept",
                signal.name
            );
            std::process::exit(i32::from(INTERRUPTED));
        }
    });
}

/// A sweep never exits from its handler: it forwards the press to its children and waits for
/// them, so no run is left writing after the sweep has gone.
pub(crate) fn install_sweep_ctrl_c_handler() {
    set_ctrl_c_handler(|signal| {
        if INTERRUPTS.fetch_add(1, Ordering::SeqCst) == 0 {
            eprintln!(
                "\nhost-trainer: {}: stopping the sweep: no new run starts, running runs write a checkpoint and stop ({} stops them at once)",
                signal.name,
                signal.again
            );
        }
    });
}

/// Counts the end of standard input as a Ctrl-C press: the parent that holds the other end has
/// gone (the kernel closes a dead process's pipes, whatever killed it).
pub(crate) fn stop_when_parent_goes() {
    std::thread::spawn(|| {
        let mut buf = [0u8; 64];
        loop {
            match std::io::stdin().read(&mut buf) {
                Ok(0) | Err(_) => break,
                Ok(_) => {}
            }
        }
        if INTERRUPTS.fetch_add(1, Ordering::SeqCst) == 0 {
            eprintln!("host-trainer: the sweep that started this run has gone; stopping and writing a checkpoint");
        }
    });
}

/// A stopping signal as the messages name it.
#[derive(Clone, Copy)]
struct Stop {
    /// The signal, e.g. "Ctrl-C" or "SIGTERM".
    name: &'static str,
    /// How to stop at once, e.g. "Ctrl-C again".
    again: &'static str,
}

fn stop_of(signal: i32) -> Stop {
    use signal_hook::consts::{SIGHUP, SIGTERM};
    match signal {
        SIGTERM => Stop {
            name: "SIGTERM",
            again: "a second SIGTERM",
        },
        SIGHUP => Stop {
            name: "SIGHUP (the terminal closed)",
            again: "a second signal",
        },
        _ => Stop {
            name: "Ctrl-C",
            again: "Ctrl-C again",
        },
    }
}

/// Calls `handler` on a thread of its own for each SIGINT, SIGTERM and SIGHUP, with the signal
/// named. signal-hook's iterator rather than ctrlc: ctrlc calls one handler for all three and
/// cannot say which came. Installed once per process; a second call adds nothing.
fn set_ctrl_c_handler(handler: fn(Stop)) {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    static INSTALLED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
    if INSTALLED.swap(true, Ordering::SeqCst) {
        return;
    }
    // Without a handler a signal still ends the process, losing at most `checkpoint_every`
    // episodes: worth a warning, not a failure.
    match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(mut signals) => {
            std::thread::spawn(move || {
                for signal in signals.forever() {
                    handler(stop_of(signal));
                }
            });
        }
        Err(e) => eprintln!("host-trainer: warning: no Ctrl-C handler ({e}); Ctrl-C loses the episodes since the last checkpoint"),
    }
}
