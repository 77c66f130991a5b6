#!/usr/bin/env bash
# cortex-m.sh -- build the example firmware (firmware/) for a Cortex-M4F, a Cortex-M3 and a RISC-V
# RV32IMAC and the example C firmware (firmware-c/) for the Cortex-Ms and a Cortex-M0, run them
# under QEMU on several blobs, check their actions bit for bit against policy-core on the host,
# and write a resource report (flash, static RAM, peak stack, instructions per `act`, boot cost,
# the C API's stack per call); then boot the M4F firmware on the A/B slot cases (which slot runs,
# fallback, safe state).
#
# The firmware holds no blob: policies live in two flash slots after it (firmware/mps2/memory.x), and
# each run loads a slot image (policy-core's slot record: a 16-byte header with a sequence number,
# then the blob) with QEMU's `-device loader,file=IMAGE,addr=ADDR`, as a flasher would write it.
# So each target and profile is built once, and every blob runs on the same firmware bytes.
# The blobs: the given --blob ("trained"), and
# deterministic ones from `host-check gen`: tanh 2x32, 4x48 and 6x64, and a ReLU 3x40, all f32;
# blobs for other plants (the firmware takes its sizes from the blob): a tanh 2x32 of 3
# observations and 1 action (a cart) on both chips, a ReLU 4x48 of 6 and 2 (a two-joint arm);
# ReLU 2x32, 4x48 and 6x64 with f16 and int8 weights (`gen --encoding`; the same f32 weights,
# quantised by policy-core's writer), and the trained blob re-encoded in f16 and int8
# (`host-check encode`). Every variant is built with the release profile (opt-level 3) except
# m4f-4x48-relu-int8-size, the same firmware optimised for size (profile release-size in
# firmware/Cargo.toml, opt-level "z"; SIZE_OPT_LEVEL=s builds it at "s"), so that the report has
# the int8 4x48 at both: the fewest instructions (3) and the least flash (z). Every firmware runs
# all three float-computing weight encodings (it reads the encoding from the blob) except the
# m4f-4x48-relu-int8-only* variants: the int8-only firmware (`--no-default-features --features
# int8`, which links neither the f32 nor the f16 kernels), at opt-levels 3, "s" (profile
# release-s) and "z" (release-size), the one that must fit 32 KiB with its blob, and the
# *-integer* variants (below).
# The c-* variants run the example C firmware (firmware-c/, C11 built with Debian's GNU Arm
# toolchain) on the same blobs: policy-core's C API (policy-core-ffi) built as a static library
# for the target (release profile, fat LTO, -Zbuild-std=core) and linked into a C program that
# prints the same lines as the Rust firmware, so host-check checks and measures both alike. A
# second build of it (-DMEASURE_CALLS, run once more; not in the flash figures) measures the
# stack of every call of the C API one by one (a STACK_PHASE line each, the report's
# stack_per_call and its second table), the critic's and the discrete policy's calls on two more
# slot records loaded beside the slots: policy-core's golden critic_2x32 and the conformance blob
# discrete-2x8-relu-f32. The c-m0-* variants run the C firmware on a
# Cortex-M0 (thumbv6m-none-eabi, QEMU's microbit: an nRF51822, 256 KiB of flash, 16 KiB of
# RAM; the layout of firmware-c/nrf51/memory.x, 88 KiB slots).
# m0-integer-minimal runs firmware-m0/, the whole Cortex-M0 firmware at its smallest (its own
# crate: policy-core with `integer`, `small-crc` and `float-free-verify` alone, opt-level "z",
# no core::fmt): A/B
# slots with full verification, the trained integer actor run from ten fixed observation codes
# through the integer entry (Model::act_codes_in), no float arithmetic in the image (the build
# fails the variant if nm finds a soft-float routine); host-check checks its unit codes against
# the host's integer entry.
# The rv32-* variants run the same Rust firmware on a RISC-V RV32IMAC without an FPU
# (riscv32imac-unknown-none-elf, riscv-rt; QEMU's sifive_e, a SiFive FE310: flash from
# 0x20400000, 16 KiB of RAM; the layout of firmware/fe310/memory.x, 128 KiB slots), with
# semihosting through `ebreak` for its output and exit, checked and measured like the Cortex-M
# ones: the trained blob in each encoding, a generated f32 tanh 4x48, f16 and int8 ReLU 4x48.
# Another RISC-V variant is one line in ALL_VARIANTS below.
# The *-trained-integer* variants (M4F, M3, RV32, and c-m0-integer on the M0) run the trained
# actor in the integer encoding (int8 weights and activations, int32 accumulators; policy-core's
# feature `integer`): --integer-blob, by default the file beside --blob with -integer before
# .postcard (models/nav-walls__dcp-paper__0-integer.postcard, made from the trained blob by
# host-trainer's integer_error example, which calibrates as `export --encoding integer` does:
# on firmware-sim's test episodes, which host-check does not link, so it is committed rather
# than generated here). The Rust firmware's feature `integer` is opt-in: m4f-, m3- and
# rv32-trained-integer build it with all four encodings. The *-trained-integer-only variants build the Rust firmware with that
# encoding alone (`--no-default-features --features integer`: no f32, f16 or int8 kernels) on
# the M3 and the RV32, chips without an FPU.
# The *-2x13-integer-3x5 variants (M4F, M3, RV32) run a generated integer actor whose every size
# is odd or off a multiple of four (3 observations, 13 wide, 5 actions; host-check gen calibrates
# it): each layer has an input left over after the pairs and outputs left over after the blocks
# of four, the paths the trained 4x48 never takes, through the M4F's SMLAD kernel and the
# portable four-output loop alike. They reuse the builds of the trained integer variants.
# The f405-* variants run the same Rust firmware ported to a real board, an STM32F405RG
# (feature stm32f405: the Olimex STM32-H405's memory map, firmware/stm32f405/memory.x, and its
# board module, clocks and USART1 set up with the vendor HAL), under QEMU's model of that board
# (olimex-stm32-h405). Its console is USART1, not semihosting: QEMU writes it to the variant's
# log and is stopped at the firmware's last line (DONE or FAIL), which stands for the exit
# status. Its slot images go in as Intel HEX at the board's flash addresses (0x08040000), as
# probe-rs writes them. The HIL checks include it through a pty, the board's serial path.
#
# Usage: bash scripts/cortex-m.sh [--blob FILE] [--out FILE] [--install-only]
#   --blob FILE     a trained policy blob (e.g. from host-trainer; any shape up to 64 wide, up to
#                   16 observations and 8 actions: the firmware runs the blob's sizes), run by the
#                   *-trained* variants (skipped without it).
#   --integer-blob FILE the trained actor in the integer encoding, run by the *-trained-integer*
#                   variants (default: --blob's file with -integer before .postcard, if it
#                   exists; else they are skipped).
#   --out FILE      JSON report path (default: <target dir>/cortex-m-report.json).
#   --install-only  install the toolchain and QEMU, then stop.
#   --no-slot-cases skip the A/B slot cases (they run by default).
#   --no-hil        skip the hardware-in-the-loop checks (they run by default, last): the HIL
#                   firmware (feature hil) for both chips and the STM32F405 board,
#                   `firmware-sim run --hil` equal to the host loop on --blob (default
#                   models/nav-walls__dcp-paper__0.postcard), its failure cases.
#   --hil-only      build the HIL firmware and run the HIL checks alone (firmware-sim --hil finds
#                   it at <target dir>/cortex-m/hil/m4f|m3/firmware.elf).
#   --refine-run DIR a run folder with policy.postcard and critic.postcard: the *-refine*
#                   variants run that actor with DCP's compare step on the device (feature
#                   `refine`, the critic in the CRITIC region), T = 4 and 16 proposals per tick
#                   (skipped without it).
# Budgets: firmware/budgets.txt limits flash, RAM and instructions per multiply-accumulate of
# named variants (the aims docs/performance.md reports as met); a variant that passes one makes
# the script exit non-zero with the variant, the figure and the budget. Its `toolchain` line pins
# the compiler the figures belong to (a Debian rustc-web version, rustc's release and LLVM):
# the script installs that version and refuses to run with another.
# Environment: PREFIX (private compiler prefix, default /opt/rust-web), RUST_WEB_VERSION (the
# Debian rustc-web version; default: the pin in firmware/budgets.txt; another one stops the
# script before it builds, as the budgets belong to the pinned one), VARIANTS (space-separated subset of the names below), EXTRA_FEATURES
# (firmware features, if any), QEMU_TIMEOUT (seconds, default 60), SIZE_OPT_LEVEL (opt-level of
# the release-size profile: z (default) or s),
# CARGO_TARGET_DIR (everything this script builds goes under <it or target/>/cortex-m).
#
# Works as root (or with sudo) on a fresh Debian 12 x86_64 machine whose rustup toolchain has only
# the host target, with only Debian apt and crates.io reachable. The route avoids rustup targets
# entirely:
#   * compiler: Debian's rustc-web + rust-web-src unpacked with dpkg -x into PREFIX (they Conflict
#     with rustup, so they are never installed); `core` is built from source with -Zbuild-std;
#   * linker: Debian's lld-NN, NN = the LLVM major rustc-web links against;
#   * C compiler for the c-* variants: Debian's gcc-arm-none-eabi (freestanding: no newlib);
#   * emulator: qemu-system-arm and qemu-system-riscv (with the opensbi it depends on) from
#     bookworm-backports (bookworm's 7.2 would remove qemu-utils 10; qemu-system-riscv is the part
#     of qemu-system-misc that holds qemu-system-riscv32), with a tiny TCG plugin
#     (firmware/qemu-plugin/icount.c, the same for both architectures) for exact instruction counts.
# A second run finds everything in place, makes no network access for the toolchain, and only
# rebuilds what changed. Exit status: 0 = every variant built, ran, matched the host and stayed
# within its budgets (firmware/budgets.txt).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PREFIX=${PREFIX:-/opt/rust-web}
BUDGETS=$ROOT/firmware/budgets.txt
# The pin: `toolchain rustc-web DEBIAN_VERSION rustc RELEASE llvm LLVM_VERSION`.
read -r _ _ PIN_DEBIAN _ PIN_RELEASE _ PIN_LLVM < <(grep -m1 '^toolchain ' "$BUDGETS") \
  || { echo "cortex-m.sh: error: $BUDGETS: expected a 'toolchain rustc-web VERSION rustc RELEASE llvm VERSION' line, found none" >&2; exit 1; }
RUST_WEB_VERSION=${RUST_WEB_VERSION:-$PIN_DEBIAN}
BASE=$(realpath -m "${CARGO_TARGET_DIR:-$ROOT/target}")
WORK=$BASE/cortex-m
OUT=$BASE/cortex-m-report.json
BLOB=
INTEGER_BLOB=
INSTALL_ONLY=0
SLOT_CASES=1
HIL=1; HIL_ONLY=0; FAILED=()
REFINE_RUN=
QEMU_TIMEOUT=${QEMU_TIMEOUT:-60}
# name:target:qemu machine:qemu cpu:blob[:profile[:refine T[:encodings[:firmware]]]]. The machine
# picks the emulator (qemu_for: sifive_e runs on qemu-system-riscv32). blob: trained
# (= --blob) or DEPTHxWIDTH-ACTIVATION (host-check gen), either with an optional -f16 or -int8
# (re-encoded; default f32), the generated ones with an optional _OxA (O observations, A
# actions; default 2x2), trained-integer (--integer-blob) or refine-actor (--refine-run's
# policy). profile: a cargo profile of
# firmware/Cargo.toml, default release. refine T: the firmware's feature `refine` with
# REFINE_T=T, --refine-run's critic in its CRITIC region. encodings: the weight encodings the
# firmware is built to run, comma-separated (`--no-default-features --features LIST`); default
# all three (f32, f16, int8; `integer` is opt-in). firmware: rust (firmware/, the default),
# stm32f405 (firmware/ with feature stm32f405: the board's memory map and USART1 console), c
# (firmware-c/ linked with policy-core-ffi's static library built with the profile) or m0
# (firmware-m0/, its own release profile at opt-level "z"; encodings then only labels the report).
M4F=thumbv7em-none-eabihf:mps2-an386:cortex-m4
M3=thumbv7m-none-eabi:mps2-an385:cortex-m3
M0=thumbv6m-none-eabi:microbit:cortex-m0
RV32=riscv32imac-unknown-none-elf:sifive_e:sifive-e31
F405=thumbv7em-none-eabihf:olimex-stm32-h405:cortex-m4
ALL_VARIANTS=(
  m4f-trained:$M4F:trained
  m4f-trained-f16:$M4F:trained-f16
  m4f-trained-int8:$M4F:trained-int8
  m4f-2x32:$M4F:2x32-tanh
  m4f-3x40:$M4F:3x40-relu
  m4f-4x48:$M4F:4x48-tanh
  m4f-6x64:$M4F:6x64-tanh
  m4f-2x32-3x1:$M4F:2x32-tanh_3x1
  m4f-4x48-6x2:$M4F:4x48-relu_6x2
  m4f-2x32-relu-f16:$M4F:2x32-relu-f16
  m4f-2x32-relu-int8:$M4F:2x32-relu-int8
  m4f-4x48-relu-f16:$M4F:4x48-relu-f16
  m4f-4x48-relu-int8:$M4F:4x48-relu-int8
  m4f-6x64-relu-f16:$M4F:6x64-relu-f16
  m4f-6x64-relu-int8:$M4F:6x64-relu-int8
  m3-trained:$M3:trained
  m3-2x32:$M3:2x32-tanh
  m3-3x40:$M3:3x40-relu
  m3-4x48:$M3:4x48-tanh
  m3-6x64:$M3:6x64-tanh
  m3-2x32-3x1:$M3:2x32-tanh_3x1
  m3-2x32-relu-f16:$M3:2x32-relu-f16
  m3-2x32-relu-int8:$M3:2x32-relu-int8
  m3-4x48-relu-f16:$M3:4x48-relu-f16
  m3-4x48-relu-int8:$M3:4x48-relu-int8
  m3-6x64-relu-f16:$M3:6x64-relu-f16
  m3-6x64-relu-int8:$M3:6x64-relu-int8
  m4f-4x48-relu-int8-size:$M4F:4x48-relu-int8:release-size
  m4f-4x48-relu-int8-only:$M4F:4x48-relu-int8:release::int8
  m4f-4x48-relu-int8-only-s:$M4F:4x48-relu-int8:release-s::int8
  m4f-4x48-relu-int8-only-size:$M4F:4x48-relu-int8:release-size::int8
  m4f-trained-integer:$M4F:trained-integer:release::f32,f16,int8,integer
  m3-trained-integer:$M3:trained-integer:release::f32,f16,int8,integer
  m3-trained-integer-only:$M3:trained-integer:release::integer
  m4f-2x13-integer-3x5:$M4F:2x13-relu-integer_3x5:release::f32,f16,int8,integer
  m3-2x13-integer-3x5:$M3:2x13-relu-integer_3x5:release::integer
  m4f-refine-actor:$M4F:refine-actor
  m4f-refine4:$M4F:refine-actor:release:4
  m4f-refine16:$M4F:refine-actor:release:16
  c-m4f-trained:$M4F:trained:release:::c
  c-m4f-4x48:$M4F:4x48-tanh:release:::c
  c-m3-trained:$M3:trained:release:::c
  c-m0-trained:$M0:trained:release:::c
  c-m0-4x48:$M0:4x48-tanh:release:::c
  c-m0-4x48-relu-int8:$M0:4x48-relu-int8:release:::c
  c-m0-integer:$M0:trained-integer:release:::c
  m0-integer-minimal:$M0:trained-integer:release::integer:m0
  rv32-trained:$RV32:trained
  rv32-trained-f16:$RV32:trained-f16
  rv32-trained-int8:$RV32:trained-int8
  rv32-4x48:$RV32:4x48-tanh
  rv32-4x48-relu-f16:$RV32:4x48-relu-f16
  rv32-4x48-relu-int8:$RV32:4x48-relu-int8
  rv32-trained-integer:$RV32:trained-integer:release::f32,f16,int8,integer
  rv32-trained-integer-only:$RV32:trained-integer:release::integer
  rv32-2x13-integer-3x5:$RV32:2x13-relu-integer_3x5:release::integer
  f405-trained:$F405:trained:release:::stm32f405
  f405-4x48-relu-int8:$F405:4x48-relu-int8:release:::stm32f405
)
# The opt-level of each profile the variants use (firmware/Cargo.toml; release-size's is set
# here, through cargo's CARGO_PROFILE_RELEASE_SIZE_OPT_LEVEL), for the report.
SIZE_OPT_LEVEL_SET=${SIZE_OPT_LEVEL:-}
SIZE_OPT_LEVEL=${SIZE_OPT_LEVEL:-z}
case $SIZE_OPT_LEVEL in 0|1|2|3|s|z) ;; *) echo "cortex-m.sh: error: SIZE_OPT_LEVEL=$SIZE_OPT_LEVEL: expected 0-3, s or z" >&2; exit 1 ;; esac
declare -A OPT_LEVEL=([release]=3 [release-s]=s [release-size]=$SIZE_OPT_LEVEL)

T_START=$SECONDS; T_LAST=$SECONDS; TIMINGS=()
step() {
  local now=$SECONDS
  [ -n "${CUR_STEP:-}" ] && TIMINGS+=("$(printf '%4ss  %s' $((now - T_LAST)) "$CUR_STEP")")
  T_LAST=$now; CUR_STEP=$*; echo "=== [$((now - T_START))s] $*"
}
die() { echo "cortex-m.sh: error: $*" >&2; exit 1; }

while [ $# -gt 0 ]; do
  case $1 in
    --blob) [ $# -ge 2 ] || die "--blob needs a file"; BLOB=$(realpath "$2"); shift 2 ;;
    --integer-blob) [ $# -ge 2 ] || die "--integer-blob needs a file"; INTEGER_BLOB=$(realpath "$2"); shift 2 ;;
    --out) [ $# -ge 2 ] || die "--out needs a file"; OUT=$(realpath -m "$2"); shift 2 ;;
    --install-only) INSTALL_ONLY=1; shift ;;
    --no-slot-cases) SLOT_CASES=0; shift ;;
    --no-hil) HIL=0; shift ;;
    --hil-only) HIL_ONLY=1; shift ;;
    --refine-run) [ $# -ge 2 ] || die "--refine-run needs a run folder"; REFINE_RUN=$(realpath "$2"); shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument $1 (see --help)" ;;
  esac
done
[ -z "$BLOB" ] || [ -f "$BLOB" ] || die "--blob $BLOB: no such file"
[ -z "$INTEGER_BLOB" ] || [ -f "$INTEGER_BLOB" ] || die "--integer-blob $INTEGER_BLOB: no such file"
if [ -z "$INTEGER_BLOB" ] && [ -n "$BLOB" ] && [ -f "${BLOB%.postcard}-integer.postcard" ]; then
  INTEGER_BLOB=${BLOB%.postcard}-integer.postcard
fi
CRITIC_BLOB=
if [ -n "$REFINE_RUN" ]; then
  for f in policy critic; do [ -f "$REFINE_RUN/$f.postcard" ] || die "--refine-run $REFINE_RUN: no $f.postcard"; done
  CRITIC_BLOB=$REFINE_RUN/critic.postcard
fi
case $PREFIX in ""|/|/usr|/usr/*|/opt|/bin|/etc|/home|/root) die "refusing PREFIX=$PREFIX (it is replaced on reinstall)" ;; esac
command -v cargo >/dev/null || die "cargo (rustup) not found on PATH"
SUDO=; [ "$(id -u)" = 0 ] || SUDO=sudo
mkdir -p "$WORK"

#--------------------------------------------------------------------------------------------------
# Toolchain. Fast path: everything already present (no network). Slow path: private apt source
# list (no change to /etc/apt), install the non-conflicting packages, unpack rustc-web.
RUST_HOST=x86_64-unknown-linux-gnu
RUSTC_X=$PREFIX/bin/rustc
lld_major() { readlink "$PREFIX/usr/lib/rustlib/$RUST_HOST/bin/rust-lld" 2>/dev/null | sed -n 's|.*/lld-\([0-9][0-9]*\)$|\1|p'; }
qemu_major() { "${1:-qemu-system-arm}" --version 2>/dev/null | sed -n '1s/.*version \([0-9]*\)\..*/\1/p'; }
toolchain_ready() {
  local have; have=$(cat "$PREFIX/.recipe-ok" 2>/dev/null) || return 1
  [ -z "$RUST_WEB_VERSION" ] || [ "$have" = "$RUST_WEB_VERSION" ] || return 1
  local llvm; llvm=$(lld_major); [ -n "$llvm" ] && command -v "lld-$llvm" >/dev/null || return 1
  "$RUSTC_X" -V >/dev/null 2>&1 || return 1
  [ "$(qemu_major)" -ge 9 ] 2>/dev/null && [ "$(qemu_major qemu-system-riscv32)" = "$(qemu_major)" ] && command -v gcc >/dev/null && command -v size >/dev/null \
    && command -v arm-none-eabi-gcc >/dev/null
}

install_toolchain() {
  local aptd=$WORK/apt
  step "apt: private source list (bookworm, -updates, -security, -backports) + update"
  mkdir -p "$aptd"/lists/partial "$aptd"/archives/partial "$aptd"/debs
  cat > "$aptd/sources.list" <<EOF
deb http://deb.debian.org/debian bookworm main
deb http://deb.debian.org/debian bookworm-updates main
deb http://deb.debian.org/debian-security bookworm-security main
deb http://deb.debian.org/debian bookworm-backports main
EOF
  APTO=(-o "Dir::Etc::sourcelist=$aptd/sources.list" -o Dir::Etc::sourceparts=- -o "Dir::State::lists=$aptd/lists" -o "Dir::Cache::archives=$aptd/archives")
  [ "$(id -u)" = 0 ] && APTO+=(-o APT::Sandbox::User=root)
  $SUDO apt-get "${APTO[@]}" -q update >/dev/null
  local vs=${RUST_WEB_VERSION:+=$RUST_WEB_VERSION} libstd llvm rw_ver
  libstd=$(apt-cache "${APTO[@]}" show --no-all-versions "libstd-rust-web-dev$vs" | sed -n 's/^Depends:.*\(libstd-rust-web-[0-9][0-9.]*\).*/\1/p')
  [ -n "$libstd" ] || die "cannot resolve libstd-rust-web-dev$vs"
  llvm=$(apt-cache "${APTO[@]}" show --no-all-versions "$libstd$vs" | sed -n 's/^Depends:.*libllvm\([0-9][0-9]*\).*/\1/p')
  [ -n "$llvm" ] || die "cannot resolve the libllvm of $libstd"
  rw_ver=$(apt-cache "${APTO[@]}" show --no-all-versions "rustc-web$vs" | sed -n 's/^Version: //p')
  echo "rustc-web $rw_ver, $libstd, LLVM $llvm"

  step "apt install: qemu-system-arm and qemu-system-riscv (bookworm-backports), lld-$llvm, libllvm$llvm, gcc, binutils, gcc-arm-none-eabi"
  # --no-remove: abort rather than let apt remove anything already installed.
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get "${APTO[@]}" -q -y install --no-install-recommends --no-remove \
    qemu-system-arm/bookworm-backports qemu-system-riscv/bookworm-backports opensbi/bookworm-backports \
    qemu-system-common/bookworm-backports qemu-system-data/bookworm-backports \
    "libllvm$llvm" "lld-$llvm" gcc libc6-dev binutils gcc-arm-none-eabi >"$WORK/apt-install.log" \
    || { tail -20 "$WORK/apt-install.log"; die "apt-get install failed (log: $WORK/apt-install.log)"; }
  grep -E 'newly installed' "$WORK/apt-install.log" || true

  if [ "$(cat "$PREFIX/.recipe-ok" 2>/dev/null)" = "$rw_ver" ] && "$RUSTC_X" -V >/dev/null 2>&1; then
    echo "rustc-web $rw_ver already unpacked in $PREFIX"
    return
  fi
  step "download rustc-web + libstd + rust-web-src $rw_ver (apt-get download; not installed)"
  rm -f "$aptd"/debs/*.deb
  (cd "$aptd/debs" && apt-get "${APTO[@]}" -q download "rustc-web$vs" "$libstd$vs" "libstd-rust-web-dev$vs" "rust-web-src$vs" >/dev/null)
  step "unpack into $PREFIX (dpkg -x; only library/ of rust-web-src)"
  $SUDO rm -rf "$PREFIX" "$PREFIX.tmp"; $SUDO mkdir -p "$PREFIX.tmp"
  for p in rustc-web "$libstd" libstd-rust-web-dev; do $SUDO dpkg -x "$aptd"/debs/${p}_*.deb "$PREFIX.tmp"; done
  dpkg-deb --fsys-tarfile "$aptd"/debs/rust-web-src_*.deb \
    | $SUDO tar -x -C "$PREFIX.tmp" --wildcards './usr/src/rustc-*/library/*' './usr/lib/rustlib/src/*'
  $SUDO mkdir -p "$PREFIX.tmp/bin" "$PREFIX.tmp/usr/lib/rustlib/$RUST_HOST/bin"
  # rustc looks for `rust-lld` in <sysroot>/lib/rustlib/<host>/bin; Debian's lld-NN serves.
  $SUDO ln -sf "/usr/bin/lld-$llvm" "$PREFIX.tmp/usr/lib/rustlib/$RUST_HOST/bin/rust-lld"
  # librustc_driver lives in usr/lib/x86_64-linux-gnu and rustc has no RUNPATH: wrap it.
  $SUDO tee "$PREFIX.tmp/bin/rustc" >/dev/null <<EOF
#!/bin/sh
LD_LIBRARY_PATH="$PREFIX/usr/lib/x86_64-linux-gnu\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}" exec "$PREFIX/usr/bin/rustc" "\$@"
EOF
  $SUDO chmod +x "$PREFIX.tmp/bin/rustc"
  $SUDO mv "$PREFIX.tmp" "$PREFIX"
  echo "$rw_ver" | $SUDO tee "$PREFIX/.recipe-ok" >/dev/null
  rm -f "$aptd"/debs/*.deb
  du -sh "$PREFIX"
}

if toolchain_ready; then
  step "toolchain already in place: $PREFIX ($(cat "$PREFIX/.recipe-ok")), lld-$(lld_major), qemu $(qemu_major)"
else
  install_toolchain
  toolchain_ready || die "toolchain still incomplete after install"
fi
for t in thumbv7em-none-eabihf thumbv7m-none-eabi thumbv6m-none-eabi riscv32imac-unknown-none-elf; do
  "$RUSTC_X" --print target-list | grep -qx "$t" || die "rustc-web does not know $t"
done
echo "$("$RUSTC_X" -V) | $(cargo -V) | $(qemu-system-arm --version | head -1) (arm and riscv32)"
# The budgets' figures belong to the pinned compiler: another one would move them silently.
RUSTC_RELEASE=$("$RUSTC_X" -vV | sed -n 's/^release: //p'); RUSTC_LLVM=$("$RUSTC_X" -vV | sed -n 's/^LLVM version: //p')
[ "$RUSTC_RELEASE $RUSTC_LLVM" = "$PIN_RELEASE $PIN_LLVM" ] \
  || die "expected rustc $PIN_RELEASE with LLVM $PIN_LLVM (the pin in firmware/budgets.txt, rustc-web $PIN_DEBIAN), found rustc $RUSTC_RELEASE with LLVM $RUSTC_LLVM: install the pinned one, or re-measure and move the pin"
# Every budget names a variant of this script (a renamed variant would leave its budget unchecked).
for b in $(grep -v '^[[:space:]]*\(#\|toolchain \|$\)' "$BUDGETS" | awk '{print $1}' | cut -d@ -f1 | sort -u); do
  printf '%s\n' "${ALL_VARIANTS[@]}" | cut -d: -f1 | grep -qx "$b" || die "firmware/budgets.txt: expected a variant of this script, found $b"
done
[ "$INSTALL_ONLY" = 1 ] && { step done; exit 0; }

#--------------------------------------------------------------------------------------------------
# Host side: host-check (rustup's own compiler; never RUSTC=rustc-web) and the plugin.
step "host-check (blobs, host comparison, report) and the QEMU instruction-count plugin"
HOST_ENV=(env -u RUSTC -u RUSTC_BOOTSTRAP -u RUSTFLAGS -u CARGO_ENCODED_RUSTFLAGS -u CARGO_BUILD_RUSTFLAGS)
# Run from the repository root: inside firmware/ cargo would pick up the firmware's target config.
(cd "$ROOT" && "${HOST_ENV[@]}" CARGO_TARGET_DIR="$WORK/host" \
  cargo build --release --locked -q --manifest-path firmware/host-check/Cargo.toml)
HC=$WORK/host/release/host-check
# Its own tests (the budget check among them), from the same release build.
(cd "$ROOT" && "${HOST_ENV[@]}" CARGO_TARGET_DIR="$WORK/host" \
  cargo test --release --locked -q --manifest-path firmware/host-check/Cargo.toml >"$WORK/host-check-tests.log" 2>&1) \
  || { tail -20 "$WORK/host-check-tests.log"; die "host-check's tests failed (log: $WORK/host-check-tests.log)"; }
PLUGIN_SRC=$ROOT/firmware/qemu-plugin/icount.c
PLUGIN_SO=$WORK/libicount.so
if [ ! -f "$PLUGIN_SO" ] || [ "$PLUGIN_SRC" -nt "$PLUGIN_SO" ]; then
  gcc -shared -fPIC -O2 -Wall -o "$PLUGIN_SO.tmp" "$PLUGIN_SRC" && mv "$PLUGIN_SO.tmp" "$PLUGIN_SO" \
    || { rm -f "$PLUGIN_SO"; echo "plugin build failed: instruction counts fall back to SysTick + -icount"; }
fi

if [ -n "$BLOB" ]; then
  BLOB_INFO=$("$HC" info "$BLOB") || die "--blob $BLOB is not a blob the firmware can run"
  echo "--blob $BLOB holds a $BLOB_INFO: run by the *-trained* variants"
fi
if [ -n "$INTEGER_BLOB" ]; then
  INTEGER_INFO=$("$HC" info "$INTEGER_BLOB") || die "--integer-blob $INTEGER_BLOB is not a blob the firmware can run"
  echo "--integer-blob $INTEGER_BLOB holds a $INTEGER_INFO: run by the *-trained-integer* variants"
fi
mkdir -p "$WORK/blobs"
blob_for() { # trained[-ENC] | DEPTHxWIDTH-ACTIVATION[-ENC][_OxA] -> blob path (given, re-encoded or generated)
  local which=$1 enc=f32 sizes=() tag=
  case $which in *_*x*) tag=_${which##*_}; sizes=(--observations "${tag%x*}" --actions "${tag##*x}"); sizes[1]=${sizes[1]#_}; which=${which%_*} ;; esac
  case $which in trained-integer) ;; *-f16|*-int8|*-integer) enc=${which##*-}; which=${which%-*} ;; esac
  local out=$WORK/blobs/actor_$which-$enc$tag.postcard
  [ "$which" = refine-actor ] && { echo "$REFINE_RUN/policy.postcard"; return; }
  [ "$which" = trained-integer ] && { echo "$INTEGER_BLOB"; return; }
  if [ "$which" = trained ]; then
    [ "$enc" = f32 ] && { echo "$BLOB"; return; }
    "$HC" encode "$BLOB" "$out" --encoding "$enc" >&2
  else
    "$HC" gen "${which%-*}" "$out" --activation "${which##*-}" --encoding "$enc" "${sizes[@]}" >&2
  fi
  echo "$out"
}

#--------------------------------------------------------------------------------------------------
# Variants: build (one shared target dir: `core`, nalgebra and policy-core are built once per
# target; another blob only relinks the firmware), run under QEMU with a timeout, compare with the
# host, measure.
FW_ENV=(env -u RUSTFLAGS -u CARGO_ENCODED_RUSTFLAGS -u CARGO_BUILD_RUSTFLAGS RUSTC="$RUSTC_X" RUSTC_BOOTSTRAP=1 CARGO_TARGET_DIR="$WORK/fw"
  CARGO_PROFILE_RELEASE_SIZE_OPT_LEVEL="$SIZE_OPT_LEVEL")
QEMU_ARGS=(-nographic -semihosting-config enable=on,target=native -icount shift=0)
# The emulator of a QEMU machine: the RISC-V's sifive_e, else an Arm board.
qemu_for() { case $1 in sifive_e) echo qemu-system-riscv32 ;; *) echo qemu-system-arm ;; esac; }
# The address of a slot (a or b) in a firmware ELF: memory.x's _slot_a / _slot_b symbols.
slot_addr() { # ELF a|b|critic|probe_critic|probe_discrete -> _slot_a, _slot_b, _critic, ... address
  local sym=_slot_$2; case $2 in critic|probe_*) sym=_$2 ;; esac
  local a; a=$(nm "$1" | awk -v s="$sym" '$3==s{print $1}'); [ -n "$a" ] || die "no $sym symbol in $1"; echo "0x$a"; }
# run_qemu DIR MACHINE CPU [ADDR IMAGE]...: boots DIR/firmware.elf with each IMAGE loaded at its
# ADDR (a flasher's job on a board; ADDR "hex": an Intel HEX image, at the addresses inside it);
# the firmware's output goes to DIR/firmware.log and the plugin's counts to DIR/plugin.log
# (plugin_log is set for host-check). Returns QEMU's status; on the STM32F405 board, whose
# console is its USART, 0 for a last line DONE, 1 for FAIL, 124 for neither within the timeout.
# On sifive_e a raw IMAGE goes as Intel HEX at ADDR (IMAGE.hex): QEMU's loader takes a raw image
# only up to the machine's RAM size, 16 KiB there.
run_qemu() {
  local dir=$1 machine=$2 cpu=$3; shift 3
  local loaders=() plugin_args=() image
  while [ $# -ge 2 ]; do
    image=$2
    if [ "$1" = hex ]; then
      loaders+=(-device "loader,file=$image"); shift 2; continue
    fi
    if [ "$machine" = sifive_e ] && [ "${image%.bin}" != "$image" ]; then
      image=${image%.bin}.hex; "$HC" hex "$2" "$image" --address "$1" >/dev/null
    fi
    loaders+=(-device "loader,file=$image,addr=$1"); shift 2
  done
  plugin_log=()
  if [ -f "$PLUGIN_SO" ]; then
    local mark; mark=$(nm "$dir/firmware.elf" | awk '$3=="fw_mark"{print $1}')
    [ -n "$mark" ] || die "$dir: no fw_mark symbol in the firmware"
    # The plugin is the same on every architecture; `& ~1` drops the Cortex-M's Thumb bit (a
    # RISC-V function is at least 2-aligned: a no-op there).
    plugin_args=(-plugin "$PLUGIN_SO,mark=$(printf '0x%x' $((0x$mark & ~1)))" -d plugin)
    plugin_log=(--plugin-log "$dir/plugin.log")
  fi
  if [ "$machine" = olimex-stm32-h405 ]; then
    run_qemu_serial "$dir" "$machine" "$cpu" "${plugin_args[@]}" "${loaders[@]}"; return
  fi
  timeout "$QEMU_TIMEOUT" "$(qemu_for "$machine")" "${QEMU_ARGS[@]}" -M "$machine" -cpu "$cpu" "${plugin_args[@]}" "${loaders[@]}" \
    -kernel "$dir/firmware.elf" </dev/null >"$dir/firmware.log" 2>"$dir/plugin.log"
}

# One A/B slot case: ELF booted under QEMU (MACHINE, CPU) in CASES/NAME with IMAGES/IMG_A at A_ADDR
# and IMAGES/IMG_B at B_ADDR ("-": the slot left empty), its exit status (1 for the safe state,
# else 0) and its log checked by `host-check slot-case` against EXPECT (A, B or safe), the blob
# RUNS that must run ("-": none) and the REASON a failed slot must give ("-": not checked). A case
# that passes appends its JSON to the array named RESULTS; one that fails is added to FAILED.
slot_case() { # RESULTS CASES ELF IMAGES A_ADDR B_ADDR MACHINE CPU NAME EXPECT RUNS REASON IMG_A IMG_B
  local -n results=$1
  local cases=$2 elf=$3 images=$4 a_addr=$5 b_addr=$6 machine=$7 cpu=$8
  local cname=$9 expect=${10} runs=${11} reason=${12} img_a=${13} img_b=${14}
  step "slot case $cname: expect $expect"
  local dir=$cases/$cname rc want_rc loads=() args=()
  mkdir -p "$dir"; cp "$elf" "$dir/firmware.elf"
  [ "$img_a" = - ] || loads+=("$a_addr" "$images/$img_a")
  [ "$img_b" = - ] || loads+=("$b_addr" "$images/$img_b")
  set +e
  run_qemu "$dir" "$machine" "$cpu" "${loads[@]}"
  rc=$?
  set -e
  want_rc=0; [ "$expect" = safe ] && want_rc=1
  if [ $rc != $want_rc ]; then
    tail -n 5 "$dir/firmware.log"
    FAILED+=("slot case $cname: QEMU exit status $rc, expected $want_rc"); return 0
  fi
  args=(--name "$cname" --expect "$expect" --fw-log "$dir/firmware.log" "${plugin_log[@]}" --out "$dir/case.json")
  [ "$runs" = - ] || args+=(--blob "$runs")
  [ "$reason" = - ] || args+=(--reason "$reason")
  if ! "$HC" slot-case "${args[@]}"; then FAILED+=("slot case $cname"); return 0; fi
  results+=("$dir/case.json")
}
# The STM32F405 board (f405-* variants): no semihosting, so no exit status from the firmware.
# Its USART1 goes to DIR/firmware.log; QEMU runs until the log's last line is DONE or FAIL (the
# firmware then parks its core) and is stopped there.
run_qemu_serial() {
  local dir=$1 machine=$2 cpu=$3 pid last=; shift 3
  rm -f "$dir/firmware.log"
  qemu-system-arm -M "$machine" -cpu "$cpu" -nodefaults -display none -icount shift=0 "$@" \
    -serial "file:$dir/firmware.log" -kernel "$dir/firmware.elf" </dev/null >/dev/null 2>"$dir/plugin.log" &
  pid=$!
  for _ in $(seq $((QEMU_TIMEOUT * 20))); do
    last=$(grep -E '^(DONE|FAIL)' "$dir/firmware.log" 2>/dev/null | tail -1) || true
    [ -n "$last" ] && break
    kill -0 "$pid" 2>/dev/null || break
    sleep 0.05
  done
  kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null || true
  case $last in DONE) return 0 ;; FAIL*) return 1 ;; *) return 124 ;; esac
}
# The C firmware (c-* variants): policy-core-ffi as a static library for the target, built with
# the Rust firmware's release settings (fat LTO, one codegen unit, panic = abort; `core` and
# compiler_builtins' memcpy/memset from source), then firmware-c/ compiled and linked against it
# with firmware/mps2/memory.x's layout. Each target's library is built once.
# Built from the root workspace, so with policy-core's features as policy-core-ffi asks for them
# (`package`): a caller's CARGO_RESOLVER_FEATURE_UNIFICATION=workspace would add the host's `std`.
FFI_ENV=(env -u RUSTFLAGS -u CARGO_ENCODED_RUSTFLAGS -u CARGO_BUILD_RUSTFLAGS RUSTC="$RUSTC_X" RUSTC_BOOTSTRAP=1 CARGO_TARGET_DIR="$WORK/ffi"
  CARGO_RESOLVER_FEATURE_UNIFICATION=package
  CARGO_PROFILE_RELEASE_LTO=fat CARGO_PROFILE_RELEASE_CODEGEN_UNITS=1 CARGO_PROFILE_RELEASE_PANIC=abort CARGO_PROFILE_RELEASE_DEBUG=true)
C_FLAGS=(-std=c11 -O2 -g -Wall -Wextra -Werror -ffreestanding -ffunction-sections -fdata-sections)
build_c_firmware() { # TARGET OUT.elf [CFLAG...]
  local target=$1 out=$2 cpu layout=$ROOT/firmware/mps2; shift 2
  case $target in
    thumbv7em-none-eabihf) cpu=(-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16) ;;
    thumbv7m-none-eabi) cpu=(-mcpu=cortex-m3 -mthumb -mfloat-abi=soft) ;;
    # The microbit's nRF51822: its own memory.x (256 KiB of flash, 16 KiB of RAM).
    thumbv6m-none-eabi) cpu=(-mcpu=cortex-m0 -mthumb -mfloat-abi=soft); layout=$ROOT/firmware-c/nrf51 ;;
    *) die "no C flags for $target" ;;
  esac
  # `cargo rustc --crate-type staticlib`: the static library alone. Built together with the
  # rlib, LTO would keep every Rust symbol global, and libm's tanhf, for one, would no longer be
  # inlined into the forward pass (about 0.4 more instructions per MAC on a tanh 4x48).
  (cd "$ROOT" && "${FFI_ENV[@]}" cargo rustc --release --locked -p policy-core-ffi --lib --crate-type staticlib \
      -Zbuild-std=core -Zbuild-std-features=compiler-builtins-mem --target "$target" 2>&1 \
    | { grep -vE '^ +(Compiling|Downloaded|Downloading|Locking|Adding|Updating|Finished)' || true; }) || return 1
  local lib=$WORK/ffi/$target/release/libpolicy_core_ffi.a
  [ -f "$lib" ] || { echo "no $lib"; return 1; }
  arm-none-eabi-gcc "${cpu[@]}" "${C_FLAGS[@]}" "$@" -I "$ROOT/policy-core-ffi/include" \
    -nostdlib -Wl,--gc-sections -Wl,-z,noexecstack -L "$layout" -T "$ROOT/firmware-c/link.ld" \
    "$ROOT"/firmware-c/{main,startup,console}.c "$lib" -lgcc -o "$out"
}
# The two slot records the C firmware measures the critic's and the discrete policy's calls on
# (firmware-c/link.ld's probe regions), and the calls every c-* variant must report.
PROBE_CRITIC=$ROOT/policy-core/tests/golden/critic_2x32.postcard
PROBE_DISCRETE=$ROOT/policy-core/conformance/blobs/discrete-2x8-relu-f32.blob
C_CALLS="dcp_abi_version dcp_abi_check dcp_slot_choose dcp_slot_read dcp_verify dcp_model_load
  dcp_model_for_policy dcp_model_header dcp_scratch_floats dcp_action_bounds dcp_act
  dcp_status_name dcp_act+error dcp_model_for_policy+error dcp_q dcp_choose dcp_choice_q"

#==================================================================================================
# HIL (hardware in the loop) -- begin. The HIL firmware (feature `hil`: after the same boot it
# serves `act` over UART0) for both chips, then `firmware-sim run --hil` against the host loop:
# the same report and trajectories bit for bit (JSON without its timing and chip fields, and
# the SVG), on the M4F with f32 and int8 weights and on the M3 with f32; through QEMU's UART on
# a socket and through a pty (the board path, `--hil serial:PATH`); the STM32F405 board's HIL
# firmware (features hil and stm32f405, USART1) on QEMU's olimex-stm32-h405 through a pty, as
# a real board on its USB-serial adapter; then the failure cases, each one line on stderr, a
# non-zero exit and no QEMU left behind.
HIL_BLOB=${BLOB:-$ROOT/models/nav-walls__dcp-paper__0.postcard}
HIL_RUN=(--scenario nav-walls --episodes 5 --seed 0 --faults dropout-nan:0.05,stuck:0@50)
hil_fail() { FAILED+=("HIL $1"); echo "HIL FAILED: $1" >&2; }
# The report without its wall-clock timing and the chip's own section (pretty JSON: fixed layout).
hil_strip() { sed '/^  "timing": {/,/^  },/d; /^  "chip": {/,/^  },/d' "$1"; }
# hil_expect NAME RC PATTERN FILE: the case's exit status was RC and FILE holds PATTERN.
hil_expect() {
  if [ "$2" != "$HIL_RC" ]; then hil_fail "$1: exit status $HIL_RC, expected $2"; tail -3 "$4" >&2; return 1; fi
  if ! grep -q -- "$3" "$4"; then hil_fail "$1: no \"$3\" in its output"; tail -3 "$4" >&2; return 1; fi
  echo "HIL $1: exit $HIL_RC, $(grep -m1 -- "$3" "$4" | sed 's/^ *//' | cut -c1-150)"
}
# hil_no_qemu NAME PID: no QEMU started by firmware-sim process PID is left.
hil_no_qemu() {
  if pgrep -f "firmware-sim-hil-$2-" >/dev/null; then hil_fail "$1: a QEMU process was left behind"; fi
}
# hil_equal NAME LINK BLOB: the host loop and the chip give the same report and trajectories.
hil_equal() {
  local name=$1 link=$2 blob=$3 d=$WORK/hil/runs/$1 rc_host rc_hil
  mkdir -p "$d"; rm -f "$d"/*
  step "HIL $name: ${HIL_RUN[*]} on the host and through --hil $link"
  set +e
  "$HIL_FS" run --blob "$blob" "${HIL_RUN[@]}" --json "$d/host.json" --svg "$d/host.svg" >"$d/host.txt" 2>&1; rc_host=$?
  "$HIL_FS" run --blob "$blob" "${HIL_RUN[@]}" --hil "$link" --json "$d/hil.json" --svg "$d/hil.svg" >"$d/hil.txt" 2>&1; rc_hil=$?
  set -e
  grep -E '^  (chip|instructions per tick)' "$d/hil.txt" || true
  [ -f "$d/hil.json" ] && [ -f "$d/host.json" ] || { hil_fail "$name: no report (exit $rc_hil)"; tail -3 "$d/hil.txt" >&2; return; }
  [ "$rc_host" = "$rc_hil" ] || { hil_fail "$name: exit status $rc_hil, the host loop's $rc_host"; return; }
  grep -q '"stopped"' "$d/hil.json" && { hil_fail "$name: the run stopped: $(grep -m1 stopped "$d/hil.txt")"; return; }
  if ! diff <(hil_strip "$d/host.json") <(hil_strip "$d/hil.json") >"$d/diff.txt"; then
    hil_fail "$name: the report differs from the host loop's ($d/diff.txt)"; return
  fi
  cmp -s "$d/host.svg" "$d/hil.svg" || { hil_fail "$name: the trajectories (SVG) differ from the host loop's"; return; }
  echo "HIL $name: the same report and trajectories as the host loop ($(grep -c '^    {$' "$d/hil.json") episodes, exit $rc_hil)"
  HIL_PASSED=$((HIL_PASSED + 1))
}
# hil_sizes NAME LINK OBS ACT: a policy for another plant, a generated tanh 2x32 of OBS
# observations and ACT actions (the firmware takes its sizes from the blob), on firmware-sim's
# null plant of those sizes run as a plant process (`serve-plant --null`), with sensor noise and
# NaN dropouts so that the observations vary: the host loop and the chip through --hil LINK must
# give the same report and send the plant the same bytes (every action, bit for bit: `tee`
# keeps the plant's input).
hil_sizes() {
  local name=$1 link=$2 o=$3 a=$4 d=$WORK/hil/runs/$1 rc_host rc_hil side
  mkdir -p "$d"; rm -f "$d"/*
  local blob=$WORK/blobs/hil-2x32-tanh_${o}x$a.postcard
  "$HC" gen 2x32 "$blob" --observations "$o" --actions "$a" >/dev/null
  step "HIL $name: a policy of $o observations and $a actions on a plant process of those sizes, on the host and through --hil $link"
  local run=(--blob "$blob" --episodes 3 --seed 0 --max-steps 100 --noise 0.5 --faults dropout-nan:0.05)
  set +e
  for side in host hil; do
    local hil=(); [ "$side" = hil ] && hil=(--hil "$link")
    "$HIL_FS" run "${run[@]}" "${hil[@]}" --json "$d/$side.json" \
      --plant-cmd "sh -c 'tee $d/$side.plant-in | $HIL_FS serve-plant --null $o,$a'" >"$d/$side.txt" 2>&1
    local rc=$?
    if [ "$side" = host ]; then rc_host=$rc; else rc_hil=$rc; fi
  done
  set -e
  grep -E '^  (chip|instructions per tick)' "$d/hil.txt" || true
  [ -f "$d/hil.json" ] && [ -f "$d/host.json" ] || { hil_fail "$name: no report (exit $rc_hil)"; tail -3 "$d/hil.txt" >&2; return; }
  [ "$rc_host" = "$rc_hil" ] || { hil_fail "$name: exit status $rc_hil, the host loop's $rc_host"; return; }
  grep -q '"stopped"' "$d/hil.json" && { hil_fail "$name: the run stopped: $(grep -m1 stopped "$d/hil.txt")"; return; }
  grep -q "2x32 f32" "$d/hil.json" || { hil_fail "$name: the chip's report names no 2x32 blob"; return; }
  if ! diff <(hil_strip "$d/host.json") <(hil_strip "$d/hil.json") >"$d/diff.txt"; then
    hil_fail "$name: the report differs from the host loop's ($d/diff.txt)"; return
  fi
  [ -s "$d/host.plant-in" ] && cmp -s "$d/host.plant-in" "$d/hil.plant-in" \
    || { hil_fail "$name: the actions the plant received differ from the host loop's"; return; }
  echo "HIL $name: the same report and the same $(stat -c %s "$d/hil.plant-in") bytes of actions into the plant as the host loop (exit $rc_hil)"
  HIL_PASSED=$((HIL_PASSED + 1))
}
# Starts QEMU with UART0 on a pty and BLOB in slot A (as a board flashed with probe-rs); sets
# HIL_PTY and HIL_QEMU_PID.
hil_pty_qemu() {
  local elf=$WORK/hil/m4f/firmware.elf d=$WORK/hil/runs/pty-qemu
  mkdir -p "$d"; rm -f "$d/qemu.log"  # a stale log would name a stale pty
  "$HC" image "$1" "$d/slot-a.bin" --sequence 1 >/dev/null
  qemu-system-arm -M mps2-an386 -cpu cortex-m4 -nodefaults -display none -icount shift=0 \
    -semihosting-config enable=on,target=native -serial pty \
    -device "loader,file=$d/slot-a.bin,addr=$(slot_addr "$elf" a)" -kernel "$elf" >"$d/qemu.log" 2>&1 &
  HIL_QEMU_PID=$!; HIL_PTY=
  for _ in $(seq 100); do
    HIL_PTY=$(sed -n 's/.*char device redirected to \(\/dev\/[^ ]*\) .*/\1/p' "$d/qemu.log")
    [ -n "$HIL_PTY" ] && break; sleep 0.1
  done
  [ -n "$HIL_PTY" ] || { hil_fail "pty: QEMU printed no pty ($(tail -1 "$d/qemu.log"))"; kill "$HIL_QEMU_PID"; wait "$HIL_QEMU_PID" || true; return 1; }
}
# The STM32F405 board's HIL firmware on QEMU's olimex-stm32-h405 with USART1 on a pty and BLOB
# in slot A as Intel HEX at its flash address (as `probe-rs download --binary-format hex`
# writes it); no semihosting, so nothing but the USART links the firmware to the host. Sets
# HIL_PTY and HIL_QEMU_PID.
hil_board_qemu() {
  local elf=$WORK/hil/f405/firmware.elf d=$WORK/hil/runs/f405-qemu
  mkdir -p "$d"; rm -f "$d/qemu.log"
  "$HC" image "$1" "$d/slot-a.hex" --sequence 1 --address "$(slot_addr "$elf" a)" >/dev/null
  qemu-system-arm -M olimex-stm32-h405 -cpu cortex-m4 -nodefaults -display none -icount shift=0 \
    -serial pty -device "loader,file=$d/slot-a.hex" -kernel "$elf" >"$d/qemu.log" 2>&1 &
  HIL_QEMU_PID=$!; HIL_PTY=
  for _ in $(seq 100); do
    HIL_PTY=$(sed -n 's/.*char device redirected to \(\/dev\/[^ ]*\) .*/\1/p' "$d/qemu.log")
    [ -n "$HIL_PTY" ] && break; sleep 0.1
  done
  [ -n "$HIL_PTY" ] || { hil_fail "f405: QEMU printed no pty ($(tail -1 "$d/qemu.log"))"; kill "$HIL_QEMU_PID"; wait "$HIL_QEMU_PID" || true; return 1; }
}
hil_checks() {
  HIL_PASSED=0
  # chip:target:features (the board's: its memory map and USART1)
  for spec in "m4f:${M4F%%:*}:hil" "m3:${M3%%:*}:hil" "f405:${F405%%:*}:hil,stm32f405"; do
    IFS=: read -r chip target features <<<"$spec"
    step "HIL firmware: build for $chip ($target, features $features)"
    if ! (cd "$ROOT/firmware" && "${FW_ENV[@]}" cargo build --release --locked -Zbuild-std=core --target "$target" --features "$features" 2>&1 \
          | { grep -vE '^ +(Compiling|Downloaded|Downloading|Locking|Adding|Updating|Finished)' || true; }); then
      hil_fail "$chip: build"; return
    fi
    mkdir -p "$WORK/hil/$chip"; cp "$WORK/fw/$target/release/policy-firmware" "$WORK/hil/$chip/firmware.elf"
  done
  step "HIL: firmware-sim (host build)"
  (cd "$ROOT" && "${HOST_ENV[@]}" CARGO_TARGET_DIR="$BASE" cargo build --locked -q -p firmware-sim) || { hil_fail "firmware-sim build"; return; }
  HIL_FS=$BASE/debug/firmware-sim
  # firmware-sim finds the HIL firmware under the target directory, where this script put it
  # (the caller's CARGO_TARGET_DIR, if any, is put back at the end).
  local had_target=${CARGO_TARGET_DIR+set} old_target=${CARGO_TARGET_DIR-}
  export CARGO_TARGET_DIR=$BASE
  local int8=$WORK/blobs/hil-trained-int8.postcard
  "$HC" encode "$HIL_BLOB" "$int8" --encoding int8 >/dev/null
  hil_equal m4f-f32 qemu-m4f "$HIL_BLOB"
  hil_equal m4f-int8 qemu-m4f "$int8"
  hil_equal m3-f32 qemu-m3 "$HIL_BLOB"
  hil_sizes m4f-cart-3x1 qemu-m4f 3 1
  # The board path: the same run through a serial port (QEMU's pty), and a second opener refused.
  if hil_pty_qemu "$HIL_BLOB"; then
    hil_equal m4f-pty "serial:$HIL_PTY" "$HIL_BLOB"
    local d=$WORK/hil/runs/busy; mkdir -p "$d"
    "$HIL_FS" run --blob "$HIL_BLOB" --episodes 20 --hil "serial:$HIL_PTY" >"$d/first.txt" 2>&1 &
    local first=$!; sleep 1
    set +e; "$HIL_FS" run --blob "$HIL_BLOB" --episodes 1 --hil "serial:$HIL_PTY" >"$d/out.txt" 2>&1; HIL_RC=$?; set -e
    hil_expect "serial port busy" 2 "is busy" "$d/out.txt" || true
    wait "$first" || true
    kill "$HIL_QEMU_PID"; wait "$HIL_QEMU_PID" 2>/dev/null || true
  fi
  # The STM32F405 board: the same run against its USART1, bit for bit.
  if hil_board_qemu "$HIL_BLOB"; then
    hil_equal f405-usart "serial:$HIL_PTY" "$HIL_BLOB"
    kill "$HIL_QEMU_PID"; wait "$HIL_QEMU_PID" 2>/dev/null || true
  fi

  step "HIL: failure cases"
  local d=$WORK/hil/runs/faults; mkdir -p "$d"; rm -rf "${d:?}"/*
  local one=(--blob "$HIL_BLOB" --episodes 1)
  set +e
  env PATH=/nonexistent "$HIL_FS" run "${one[@]}" --hil qemu-m4f >"$d/no-qemu.txt" 2>&1; HIL_RC=$?
  hil_expect "QEMU missing" 2 "qemu-system-arm not found: install it with" "$d/no-qemu.txt"
  CARGO_TARGET_DIR=$d/none "$HIL_FS" run "${one[@]}" --hil qemu-m3 >"$d/no-elf.txt" 2>&1; HIL_RC=$?
  hil_expect "HIL firmware missing" 2 "no HIL firmware at .*: build it with" "$d/no-elf.txt"
  # The chip runs a blob of any sizes; one that is not the plant's is named with both sizes.
  "$HIL_FS" run --blob "$WORK/blobs/hil-2x32-tanh_3x1.postcard" --episodes 1 --hil qemu-m4f >"$d/sizes.txt" 2>&1; HIL_RC=$?
  hil_expect "a policy for another plant" 2 "a policy of (observations, actions) = (3, 1); the plant's are (2, 2)" "$d/sizes.txt"
  "$HIL_FS" run "${one[@]}" --hil serial:"$d/no-such-tty" >"$d/no-tty.txt" 2>&1; HIL_RC=$?
  hil_expect "serial path missing" 2 "no such device" "$d/no-tty.txt"
  "$HIL_FS" run "${one[@]}" --hil qemu-m4f --tick-timeout 1 --hil-qemu-arg -S >"$d/silent.txt" 2>&1; HIL_RC=$?
  hil_expect "firmware silent (QEMU started halted)" 2 "sent nothing for 1.0 s" "$d/silent.txt"
  if [ -f "$WORK/slots/a-only/firmware.elf" ]; then
    "$HIL_FS" run "${one[@]}" --hil qemu-m4f --hil-firmware "$WORK/slots/a-only/firmware.elf" >"$d/not-hil.txt" 2>&1; HIL_RC=$?
    hil_expect "a firmware without feature hil" 2 "QEMU exited" "$d/not-hil.txt"
  fi
  "$HIL_FS" run --blob "$HIL_BLOB" "${HIL_RUN[@]}" --hil qemu-m4f --tick-budget 1000 >"$d/budget.txt" 2>&1; HIL_RC=$?
  hil_expect "tick budget exceeded" 1 "ticks took more than the tick budget of 1000 instructions" "$d/budget.txt"
  # A board reset mid-episode: QEMU's monitor (on a pipe) resets the chip while the run goes on.
  rm -f "$d/mon.in" "$d/mon.out"; mkfifo "$d/mon.in" "$d/mon.out"
  "$HIL_FS" run --blob "$HIL_BLOB" --episodes 100 --hil qemu-m4f --json "$d/reset.json" \
    --hil-qemu-arg -monitor --hil-qemu-arg "pipe:$d/mon" >"$d/reset.txt" 2>&1 &
  local pid=$!
  cat "$d/mon.out" >/dev/null &
  local drain=$!
  sleep 3; echo system_reset >"$d/mon.in"; wait "$pid"; HIL_RC=$?
  kill "$drain" 2>/dev/null; wait "$drain" 2>/dev/null
  if hil_expect "board reset mid-episode" 1 "the chip reset mid-episode" "$d/reset.txt"; then
    local ran kept
    ran=$(sed -n 's/.*"episodes_run": \([0-9]*\).*/\1/p' "$d/reset.json"); kept=$(grep -c '^    {$' "$d/reset.json")
    [ -n "$ran" ] && [ "$ran" = "$kept" ] && [ "$ran" -gt 0 ] || hil_fail "board reset: the report keeps $kept episodes, stopped says ${ran:-none}"
  fi
  hil_no_qemu "board reset" "$pid"
  # Ctrl-C: the episodes so far are reported, QEMU is stopped.
  "$HIL_FS" run --blob "$HIL_BLOB" --episodes 100 --hil qemu-m4f --json "$d/ctrlc.json" >"$d/ctrlc.txt" 2>&1 &
  pid=$!; sleep 2; kill -INT "$pid"; wait "$pid"; HIL_RC=$?
  hil_expect "Ctrl-C" 1 "interrupted (Ctrl-C)" "$d/ctrlc.txt" && { grep -q '"episodes_run"' "$d/ctrlc.json" || hil_fail "Ctrl-C: no report written"; }
  hil_no_qemu "Ctrl-C" "$pid"
  # kill -9 mid-run (no handler runs in firmware-sim): QEMU dies with it (its parent-death
  # signal) and the run's scratch folder went when the chip said its hello. A second or two.
  "$HIL_FS" run --blob "$HIL_BLOB" --episodes 100 --hil qemu-m4f >"$d/kill9.txt" 2>&1 &
  pid=$!
  for _ in $(seq 100); do grep -q 'runs$' "$d/kill9.txt" && break; sleep 0.05; done
  if grep -q 'runs$' "$d/kill9.txt"; then
    sleep 0.5; kill -9 "$pid"; wait "$pid" 2>/dev/null
    for _ in $(seq 40); do pgrep -f "firmware-sim-hil-$pid-" >/dev/null || break; sleep 0.05; done
    hil_no_qemu "kill -9" "$pid"
    if compgen -G "${TMPDIR:-/tmp}/firmware-sim-hil-$pid-*" >/dev/null; then
      hil_fail "kill -9: the run's scratch folder was left"
    else
      echo "HIL kill -9: no QEMU and no scratch folder left"
    fi
  else
    hil_fail "kill -9: the run did not start ($(tail -1 "$d/kill9.txt"))"; kill -9 "$pid"; wait "$pid" 2>/dev/null
  fi
  set -e
  if [ -n "$had_target" ]; then export CARGO_TARGET_DIR=$old_target; else unset CARGO_TARGET_DIR; fi
}
# HIL (hardware in the loop) -- end
#==================================================================================================

# --hil-only: the HIL firmware and its checks alone (HIL block above).
if [ "$HIL_ONLY" = 1 ]; then
  hil_checks
  step done
  [ ${#FAILED[@]} = 0 ] || { printf 'FAILED: %s\n' "${FAILED[@]}" >&2; exit 1; }
  echo "RESULT: PASS (HIL: $HIL_PASSED runs equal to the host loop; failure cases as expected)"; exit 0
fi
SELECTED=(${VARIANTS:-$(printf '%s\n' "${ALL_VARIANTS[@]}" | cut -d: -f1)})
JSONS=()
for spec in "${ALL_VARIANTS[@]}"; do
  IFS=: read -r name target machine cpu which profile refine encodings firmware <<<"$spec"
  profile=${profile:-release}
  printf '%s\n' "${SELECTED[@]}" | grep -qx "$name" || continue
  case $which in trained|trained-*) [ -n "$BLOB" ] || { echo "=== $name: skipped (no --blob)"; continue; } ;; esac
  case $which in trained-integer) [ -n "$INTEGER_BLOB" ] || { echo "=== $name: skipped (no --integer-blob)"; continue; } ;; esac
  case $which in refine-actor) [ -n "$REFINE_RUN" ] || { echo "=== $name: skipped (no --refine-run)"; continue; } ;; esac
  features=${EXTRA_FEATURES:-}; refine_env=()
  if [ -n "$refine" ]; then features=${features:+$features,}refine; refine_env=(REFINE_T="$refine"); fi
  encoding_args=()
  if [ -n "$encodings" ]; then features=${features:+$features,}$encodings; encoding_args=(--no-default-features); fi
  [ "${firmware:-rust}" = stm32f405 ] && features=${features:+$features,}stm32f405
  dir=$WORK/variants/$name; mkdir -p "$dir"; rm -f "$dir"/*.log "$dir/resources.json"
  blob=$(blob_for "$which")

  if [ "${firmware:-rust}" = m0 ]; then
    # firmware-m0/: its own crate (policy-core with `integer` alone, opt-level "z"), no features.
    step "$name: build firmware-m0 ($target, opt-level z, integer only; no blob inside)"
    if ! (cd "$ROOT/firmware-m0" && "${FW_ENV[@]}" cargo build --release --locked -Zbuild-std=core --target "$target" 2>&1 \
          | { grep -vE '^ +(Compiling|Downloaded|Downloading|Locking|Adding|Updating|Finished)' || true; } ); then
      FAILED+=("$name: build"); continue
    fi
    cp "$WORK/fw/$target/release/policy-firmware-m0" "$dir/firmware.elf" || { FAILED+=("$name: build produced no ELF"); continue; }
    # No soft-float routine may be linked: the firmware runs the integer entry from codes.
    if nm "$dir/firmware.elf" | grep -E ' __aeabi_[fd](add|sub|mul|div|cmp|2|to)| __(add|sub|mul|div)[sd]f3' >"$dir/float.txt"; then
      FAILED+=("$name: soft-float routines linked: $(awk '{print $3}' "$dir/float.txt" | tr '\n' ' ')"); continue
    fi
  elif [ "${firmware:-rust}" = c ]; then
    step "$name: build the C firmware ($target; policy-core-ffi, profile $profile; no blob inside), and again with -DMEASURE_CALLS"
    if ! build_c_firmware "$target" "$dir/firmware.elf"; then FAILED+=("$name: build"); continue; fi
    # The same firmware that then measures the stack of each call of the C API: a build of its
    # own, so that the measuring code stays out of the figures of the firmware above.
    mkdir -p "$dir/calls"; rm -f "$dir/calls"/*.log
    if ! build_c_firmware "$target" "$dir/calls/firmware.elf" -DMEASURE_CALLS; then FAILED+=("$name: build (-DMEASURE_CALLS)"); continue; fi
  else
  step "$name: build ($target, profile $profile${encodings:+, encodings $encodings only}${refine:+, refine}$([ "${firmware:-rust}" = stm32f405 ] && echo ', board stm32f405'); no blob inside)"
  if ! (cd "$ROOT/firmware" && "${FW_ENV[@]}" "${refine_env[@]}" cargo build --profile "$profile" --locked -Zbuild-std=core \
        --target "$target" "${encoding_args[@]}" ${features:+--features "$features"} 2>&1 \
        | { grep -vE '^ +(Compiling|Downloaded|Downloading|Locking|Adding|Updating|Finished)' || true; } ); then
    FAILED+=("$name: build"); continue
  fi
  elf=$WORK/fw/$target/$profile/policy-firmware
  [ -f "$elf" ] || { FAILED+=("$name: build produced no ELF"); continue; }
  cp "$elf" "$dir/firmware.elf"
  fi
  size -A "$dir/firmware.elf" > "$dir/sizes.txt"

  step "$name: run under QEMU ($machine, $cpu; $(basename "$blob") in slot A; timeout ${QEMU_TIMEOUT}s)"
  "$HC" image "$blob" "$dir/slot-a.bin" --sequence 1 >/dev/null
  loads=("$(slot_addr "$dir/firmware.elf" a)" "$dir/slot-a.bin"); critic_args=()
  if [ "${firmware:-rust}" = stm32f405 ]; then
    # The board's slot as a probe flashes it: Intel HEX at slot A's flash address.
    "$HC" image "$blob" "$dir/slot-a.hex" --sequence 1 --address "$(slot_addr "$dir/firmware.elf" a)" >/dev/null
    loads=(hex "$dir/slot-a.hex")
  fi
  if [ -n "$refine" ]; then
    "$HC" image "$CRITIC_BLOB" "$dir/critic.bin" --sequence 1 >/dev/null
    loads+=("$(slot_addr "$dir/firmware.elf" critic)" "$dir/critic.bin"); critic_args=(--critic "$CRITIC_BLOB")
  fi
  set +e
  run_qemu "$dir" "$machine" "$cpu" "${loads[@]}"
  rc=$?
  set -e
  if [ $rc != 0 ]; then
    tail -n 5 "$dir/firmware.log" "$dir/plugin.log"
    FAILED+=("$name: QEMU exit status $rc$([ $rc = 124 ] && echo ' (timeout)')"); continue
  fi

  step "$name: compare with policy-core on the host (bit-exact) and measure"
  if ! "$HC" check "$blob" "$dir/firmware.log" "${critic_args[@]}"; then FAILED+=("$name: actions differ from the host"); continue; fi
  main_plugin_log=("${plugin_log[@]}"); calls_args=()
  if [ "${firmware:-rust}" = c ]; then
    step "$name: the stack of each call of the C API (the -DMEASURE_CALLS build; a critic and a discrete policy in its probe regions)"
    "$HC" image "$PROBE_CRITIC" "$dir/calls/probe-critic.bin" --sequence 1 >/dev/null
    "$HC" image "$PROBE_DISCRETE" "$dir/calls/probe-discrete.bin" --sequence 1 >/dev/null
    set +e
    run_qemu "$dir/calls" "$machine" "$cpu" "$(slot_addr "$dir/calls/firmware.elf" a)" "$dir/slot-a.bin" \
      "$(slot_addr "$dir/calls/firmware.elf" probe_critic)" "$dir/calls/probe-critic.bin" \
      "$(slot_addr "$dir/calls/firmware.elf" probe_discrete)" "$dir/calls/probe-discrete.bin"
    rc=$?
    set -e
    if [ $rc != 0 ]; then
      tail -n 5 "$dir/calls/firmware.log"
      FAILED+=("$name: the -DMEASURE_CALLS build: QEMU exit status $rc$([ $rc = 124 ] && echo ' (timeout)')"); continue
    fi
    calls_args=(--calls-log "$dir/calls/firmware.log")
  fi
  opt_level=${OPT_LEVEL[$profile]}; [ "${firmware:-rust}" = m0 ] && opt_level=z # firmware-m0's own release profile
  if ! "$HC" measure --variant "$name" --target "$target" --machine "$machine" --cpu "$cpu" --blob "$blob" --image "$dir/slot-a.bin" \
        --profile "$profile" --opt-level "$opt_level" --encodings "${encodings:-f32,f16,int8}" --sizes "$dir/sizes.txt" --fw-log "$dir/firmware.log" "${main_plugin_log[@]}" "${critic_args[@]}" "${calls_args[@]}" --out "$dir/resources.json"; then
    FAILED+=("$name: measurement"); continue
  fi
  if [ "${firmware:-rust}" = c ]; then
    missing=$(for call in $C_CALLS; do grep -q "\"call\": \"$call\"" "$dir/resources.json" || printf ' %s' "$call"; done)
    [ -z "$missing" ] || { FAILED+=("$name: no stack figure for$missing"); continue; }
  fi
  JSONS+=("$dir/resources.json")
done

#--------------------------------------------------------------------------------------------------
# A/B slot cases of firmware-m0 (after m0-integer-minimal ran): the same choice on the M0's own
# build and layout, the trained integer blob in slot A, a generated integer 4x48 in slot B. Its
# failed slots print no reason (no core::fmt in that firmware), so the cases check which slot
# runs, that slot's codes bit-exact against its blob, or the safe state.
M0_SLOT_JSONS=()
if [ "$SLOT_CASES" = 1 ] && [ -n "$INTEGER_BLOB" ] && [ -f "$WORK/variants/m0-integer-minimal/resources.json" ] \
    && printf '%s\n' "${SELECTED[@]}" | grep -qx m0-integer-minimal; then
  step "slot cases of firmware-m0: the slot images"
  IFS=: read -r target machine cpu <<<"$M0"
  m0_elf=$WORK/variants/m0-integer-minimal/firmware.elf
  M0_A=$(slot_addr "$m0_elf" a); M0_B=$(slot_addr "$m0_elf" b)
  S0=$WORK/slots-m0; I0=$S0/img; mkdir -p "$I0"
  M0_GOOD_B=$WORK/blobs/actor_4x48-relu-integer-seed5.postcard
  "$HC" gen 4x48 "$M0_GOOD_B" --activation relu --encoding integer --seed 5 >/dev/null
  "$HC" image "$INTEGER_BLOB" "$I0/a1.bin" --sequence 1 >/dev/null
  "$HC" image "$M0_GOOD_B" "$I0/b2.bin" --sequence 2 >/dev/null
  "$HC" image "$(blob_for 2x32-relu)" "$I0/b2-f32.bin" --sequence 2 >/dev/null
  "$HC" damage "$I0/a1.bin" "$I0/a1-flipped.bin" --flip 216 >/dev/null
  "$HC" damage "$I0/b2.bin" "$I0/b2-flipped.bin" --flip 216 >/dev/null
  # name:expect:blob that runs (or -):slot A image (or -):slot B image
  for c in "m0-a-only:A:$INTEGER_BLOB:a1.bin:-" "m0-b-newer:B:$M0_GOOD_B:a1.bin:b2.bin" \
      "m0-b-flipped-byte:A:$INTEGER_BLOB:a1.bin:b2-flipped.bin" "m0-b-f32:A:$INTEGER_BLOB:a1.bin:b2-f32.bin" \
      "m0-a-empty:B:$M0_GOOD_B:-:b2.bin" "m0-both-bad:safe:-:a1-flipped.bin:b2-flipped.bin"; do
    IFS=: read -r cname expect runs img_a img_b <<<"$c"
    slot_case M0_SLOT_JSONS "$S0" "$m0_elf" "$I0" "$M0_A" "$M0_B" "$machine" "$cpu" \
      "$cname" "$expect" "$runs" - "$img_a" "$img_b"
  done
fi

#--------------------------------------------------------------------------------------------------
# A/B slot cases on the M4F (release): the same firmware, other slot contents. Each case names
# the slot that must run (its actions checked bit-exact against that slot's blob on the host) or
# the safe state (zero actions, both slots' reasons, exit status 1), and the reason a skipped slot
# must report. Images come from `host-check image` (policy-core's slot::record, as host-trainer's
# `export --image` writes them); slot B of "b-newer-hex" is Intel HEX, which QEMU's loader reads
# at the addresses inside it.
SLOT_JSONS=()
if [ "$SLOT_CASES" = 1 ]; then
  step "slot cases: build the M4F firmware (release) and the slot images"
  IFS=: read -r target machine cpu <<<"$M4F"
  (cd "$ROOT/firmware" && "${FW_ENV[@]}" cargo build --release --locked -Zbuild-std=core --target "$target" 2>&1 \
    | { grep -vE '^ +(Compiling|Downloaded|Downloading|Locking|Adding|Updating|Finished)' || true; }) \
    || die "slot cases: firmware build failed"
  elf=$WORK/fw/$target/release/policy-firmware
  A_ADDR=$(slot_addr "$elf" a); B_ADDR=$(slot_addr "$elf" b)
  S=$WORK/slots; mkdir -p "$S/img"
  GOOD_A=${BLOB:-$(blob_for 4x48-relu)}
  GOOD_B=$WORK/blobs/actor_4x48-relu-seed5.postcard
  "$HC" gen 4x48 "$GOOD_B" --activation relu --seed 5 >/dev/null
  WIDE=$WORK/blobs/actor_2x96-relu.postcard
  "$HC" gen 2x96 "$WIDE" --activation relu >/dev/null
  CRITIC=$ROOT/policy-core/tests/golden/critic_2x32.postcard
  I=$S/img
  "$HC" image "$GOOD_A" "$I/a1.bin" --sequence 1 >/dev/null
  "$HC" image "$GOOD_A" "$I/a-max.bin" --sequence 4294967295 >/dev/null
  "$HC" image "$GOOD_B" "$I/b2.bin" --sequence 2 >/dev/null
  "$HC" image "$GOOD_B" "$I/b2.hex" --sequence 2 --address "$B_ADDR" >/dev/null
  "$HC" image "$GOOD_B" "$I/b0.bin" --sequence 0 >/dev/null
  "$HC" image "$GOOD_B" "$I/b7.bin" --sequence 7 >/dev/null
  "$HC" image "$CRITIC" "$I/critic2.bin" --sequence 2 >/dev/null
  "$HC" image "$WIDE" "$I/wide2.bin" --sequence 2 >/dev/null
  "$HC" damage "$I/a1.bin" "$I/a1-flipped.bin" --flip 216 >/dev/null
  "$HC" damage "$I/b2.bin" "$I/b2-flipped.bin" --flip 216 >/dev/null
  "$HC" damage "$I/b2.bin" "$I/b2-seqflip.bin" --flip 5 >/dev/null
  "$HC" damage "$I/b2.bin" "$I/b2-cut.bin" --cut $(( $(stat -c %s "$I/b2.bin") / 2 )) >/dev/null
  "$HC" fill "$I/erased.bin" --len 4096 --byte 0xFF >/dev/null
  "$HC" fill "$I/random.bin" --len 4096 --random 7 >/dev/null
  # name:expect:blob that runs (A, B or -):reason a failed slot must give (or -):slot A image:slot B image
  CASES=(
    "a-only:A:$GOOD_A:-:a1.bin:-"
    "b-newer-hex:B:$GOOD_B:-:a1.bin:b2.hex"
    "b-flipped-byte:A:$GOOD_A:checksum mismatch:a1.bin:b2-flipped.bin"
    "both-bad:safe:-:checksum mismatch:a1-flipped.bin:erased.bin"
    "both-empty:safe:-:empty slot:-:-"
    "b-random-bytes:A:$GOOD_A:not a slot record:a1.bin:random.bin"
    "b-truncated:A:$GOOD_A:checksum mismatch:a1.bin:b2-cut.bin"
    "b-critic:A:$GOOD_A:wrong model kind:a1.bin:critic2.bin"
    "b-too-wide:A:$GOOD_A:scratch buffer too small:a1.bin:wide2.bin"
    "b-sequence-flipped:A:$GOOD_A:header corrupted:a1.bin:b2-seqflip.bin"
    "sequence-wrapped:B:$GOOD_B:-:a-max.bin:b0.bin"
    "a-erased:B:$GOOD_B:empty slot:erased.bin:b7.bin"
  )
  for c in "${CASES[@]}"; do
    IFS=: read -r cname expect runs reason img_a img_b <<<"$c"
    slot_case SLOT_JSONS "$S" "$elf" "$I" "$A_ADDR" "$B_ADDR" "$machine" "$cpu" \
      "$cname" "$expect" "$runs" "$reason" "$img_a" "$img_b"
  done
fi

# HIL checks (block above), after the variants and the slot cases.
[ "$HIL" = 1 ] && hil_checks

#--------------------------------------------------------------------------------------------------
step "report"
[ ${#JSONS[@]} -gt 0 ] || die "no variant ran: ${FAILED[*]}"
mkdir -p "$(dirname "$OUT")"
# The report, then the budgets: a budget passed is one line naming the variant, figure and budget.
set +e
"$HC" report --out "$OUT" --budgets "$BUDGETS" \
  --meta "rustc=$("$RUSTC_X" -V) (rustc-web $RUST_WEB_VERSION, LLVM $RUSTC_LLVM)" --meta "cargo=$(cargo -V)" \
  --meta "qemu=$(qemu-system-arm --version | head -1) (qemu-system-arm; qemu-system-riscv32: $(qemu-system-riscv32 --version | head -1 | sed 's/.*version //'))" \
  --meta "profile=release: opt-level 3, fat LTO, codegen-units 1, panic abort, -Zbuild-std=core; release-s: the same at opt-level s; release-size: the same at opt-level $SIZE_OPT_LEVEL (per variant: the profile column)" \
  --meta "encodings=every firmware runs f32, f16 and int8 blobs except the *-int8-only* variants (int8 only), the *-trained-integer ones (integer too) and the *-integer-only* ones (integer only; per variant: firmware_encodings)" \
  --meta "c firmware=the c-* variants: firmware-c/ (arm-none-eabi-gcc $(arm-none-eabi-gcc -dumpversion), ${C_FLAGS[*]}) linked with policy-core-ffi built with the release profile" \
  --meta "instructions=exact counts from a TCG plugin between fw_mark calls (mark cost subtracted)" \
  --meta "stack=painted: peak stack = main's frame + the largest of its phases below it (boot, act); stack_per_call (c-* variants) = each C API call alone, below the frame of the function that makes it, not in the peak" \
  --meta "command=${VARIANTS:+VARIANTS=\"$VARIANTS\" }${SIZE_OPT_LEVEL_SET:+SIZE_OPT_LEVEL=$SIZE_OPT_LEVEL }${EXTRA_FEATURES:+EXTRA_FEATURES=$EXTRA_FEATURES }bash scripts/cortex-m.sh${BLOB:+ --blob $BLOB}${REFINE_RUN:+ --refine-run $REFINE_RUN}" \
  "${JSONS[@]}" 2>"$WORK/report.err"
rc=$?
set -e
if [ $rc != 0 ]; then
  cat "$WORK/report.err" >&2
  FAILED+=("$(sed 's/^host-check: error: //' "$WORK/report.err")")
fi
if [ ${#SLOT_JSONS[@]} -gt 0 ]; then
  echo "slot cases (M4F, release; boot = choosing and verifying, in instructions):"
  "$HC" slot-table "${OUT%.json}-slots.md" "${SLOT_JSONS[@]}"
fi
if [ ${#M0_SLOT_JSONS[@]} -gt 0 ]; then
  echo "slot cases of firmware-m0 (Cortex-M0; boot = choosing and verifying, in instructions):"
  "$HC" slot-table "${OUT%.json}-slots-m0.md" "${M0_SLOT_JSONS[@]}"
fi
step done
echo "report: $OUT (table: ${OUT%.json}.md)"
echo "timings:"; printf '  %s\n' "${TIMINGS[@]}"
echo "total: $((SECONDS - T_START)) s"
if [ ${#FAILED[@]} -gt 0 ]; then
  printf 'FAILED: %s\n' "${FAILED[@]}" >&2
  exit 1
fi
echo "RESULT: PASS (${#JSONS[@]} variants bit-exact with the host; $(( ${#SLOT_JSONS[@]} + ${#M0_SLOT_JSONS[@]} )) slot cases as expected)"
