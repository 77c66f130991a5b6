//! A firmware-shaped program on the host: no std, no allocator, no C start-up code. It loads the
//! golden actor and critic blobs into `static` slots, acts, refines, and reports through its exit
//! status: 0 when every action is finite, in bounds and equal to the golden vector.
#![no_std]
#![no_main]

use core::fmt::Write;
use core::panic::PanicInfo;

use policy_core::compare::refine;
use policy_core::model::{Model, Scratch};
use policy_core::{Critic, Policy};

#[cfg(not(all(target_arch = "x86_64", target_os = "linux")))]
compile_error!("nostd-check's entry point and exit syscall are written for x86_64 Linux");

static ACTOR_BLOB: &[u8] = include_bytes!("../../policy-core/tests/golden/actor_2x32.postcard");
static CRITIC_BLOB: &[u8] = include_bytes!("../../policy-core/tests/golden/critic_2x32.postcard");

/// Where a firmware keeps its models: statics loaded once at boot (about 10 KB together).
static mut ACTOR: Policy<2, 32, 1, 2> = Policy::ZERO;
static mut CRITIC: Critic<2, 32, 1, 2> = Critic::ZERO;

/// `act([0, 0])` of the golden actor, from policy-core/tests/golden/vectors.txt.
const GOLDEN_ORIGIN: [u32; 2] = [0x3d54_7cc0, 0x3d8b_cd00];

fn check() -> Result<(), &'static str> {
    // SAFETY: the program is single-threaded and these are the only references to the slots.
    let (actor, critic) = unsafe {
        (
            &mut *core::ptr::addr_of_mut!(ACTOR),
            &mut *core::ptr::addr_of_mut!(CRITIC),
        )
    };
    let truncated = ACTOR_BLOB.split_last().map_or(ACTOR_BLOB, |(_, rest)| rest);
    if actor.load_into(truncated).is_ok() || *actor != Policy::ZERO {
        return Err("a truncated blob was accepted or changed the slot");
    }
    actor
        .load_into(ACTOR_BLOB)
        .map_err(|_| "the golden actor blob did not load")?;
    critic
        .load_into(CRITIC_BLOB)
        .map_err(|_| "the golden critic blob did not load")?;
    if actor.act(&[0.0, 0.0]).map(f32::to_bits) != GOLDEN_ORIGIN {
        return Err("act([0, 0]) differs from the golden vector");
    }
    // The runtime: the same blob, run straight from its bytes with a stack scratch.
    let model = Model::from_blob(ACTOR_BLOB).map_err(|_| "the runtime refused the golden actor")?;
    model
        .expect_sizes(2, 2)
        .map_err(|_| "the runtime reports other sizes")?;
    let mut scratch = Scratch::<32>::new();
    for obs in [[0.0, 0.0], [4.0, -2.5], [f32::NAN, f32::INFINITY]] {
        let mut a = [0.0f32; 2];
        model
            .act(&obs, &mut scratch, &mut a)
            .map_err(|_| "the runtime could not act")?;
        if a.map(f32::to_bits) != actor.act(&obs).map(f32::to_bits) {
            return Err("the runtime and the compiled actor differ");
        }
    }
    let mut rng = XorShift(0x9E37_79B9);
    for obs in [
        [4.0, -2.5],
        [f32::NAN, f32::INFINITY],
        [6.0, 6.0],
        [-1e30, 0.5],
    ] {
        let a = actor.act(&obs);
        if !a.iter().all(|v| v.is_finite() && v.abs() <= 0.25) {
            return Err("an action is not finite or out of bounds");
        }
        let r = refine(actor, critic, &obs, &mut rng, 8, 0.3);
        if critic.q(&obs, &r.unit) < critic.q(&obs, &actor.act_unit(&obs)) {
            return Err("refine returned a worse action");
        }
    }
    Ok(())
}

/// Marsaglia's xorshift32: the kind of RNG a firmware has at hand.
struct XorShift(u32);

impl rand_core::TryRng for XorShift {
    type Error = core::convert::Infallible;
    fn try_next_u32(&mut self) -> Result<u32, Self::Error> {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        Ok(self.0)
    }
    fn try_next_u64(&mut self) -> Result<u64, Self::Error> {
        Ok(u64::from(self.try_next_u32()?) << 32 | u64::from(self.try_next_u32()?))
    }
    fn try_fill_bytes(&mut self, dst: &mut [u8]) -> Result<(), Self::Error> {
        for b in dst {
            *b = self.try_next_u32()? as u8;
        }
        Ok(())
    }
}

extern "C" fn main() -> ! {
    let mut line = Line::new();
    let code = match check() {
        Ok(()) => {
            let _ = write!(
                line,
                "nostd-check: ok (policy-core loaded, acted from the blob bytes and refined without std)"
            );
            0
        }
        Err(why) => {
            let _ = write!(line, "nostd-check: FAILED: {why}");
            1
        }
    };
    line.print();
    exit(code)
}

#[panic_handler]
fn panic(_: &PanicInfo<'_>) -> ! {
    let mut line = Line::new();
    let _ = write!(line, "nostd-check: panic");
    line.print();
    exit(101)
}

// The process entry point. The kernel enters with the stack 16-byte aligned but no return
// address pushed, which is not how a Rust function expects to be entered, so a few instructions
// of assembly align the stack and call `main` as a normal function.
core::arch::global_asm!(
    ".globl _start",
    "_start:",
    "xor ebp, ebp",
    "and rsp, -16",
    "call {main}",
    "ud2",
    main = sym main,
);

/// The precompiled `core` for this target is built for unwinding and names this symbol in its
/// unwind tables; with `panic = "abort"` nothing ever calls it.
#[no_mangle]
extern "C" fn rust_eh_personality() {}

fn exit(code: i32) -> ! {
    // SAFETY: exit_group(2) (syscall 231) takes one integer and never returns.
    unsafe {
        core::arch::asm!("syscall", in("rax") 231, in("rdi") code as isize, options(noreturn, nostack));
    }
}

/// One line of text on stdout, formatted without an allocator.
struct Line {
    bytes: [u8; 120],
    len: usize,
}

impl Line {
    fn new() -> Self {
        Self {
            bytes: [0; 120],
            len: 0,
        }
    }

    fn print(&mut self) {
        let _ = self.write_str("\n");
        let text = self.bytes.get(..self.len).unwrap_or(&[]);
        // SAFETY: write(2) (syscall 1) to fd 1 reads `len` bytes from a live buffer.
        unsafe {
            core::arch::asm!(
                "syscall",
                inlateout("rax") 1isize => _,
                in("rdi") 1isize,
                in("rsi") text.as_ptr(),
                in("rdx") text.len(),
                lateout("rcx") _,
                lateout("r11") _,
                options(nostack),
            );
        }
    }
}

impl Write for Line {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let end = self.len + s.len();
        let dst = self.bytes.get_mut(self.len..end).ok_or(core::fmt::Error)?;
        dst.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}
