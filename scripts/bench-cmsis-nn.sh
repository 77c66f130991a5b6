#!/usr/bin/env bash
# Side-by-side on the Cortex-M4F: CMSIS-NN's int8 fully connected kernel and policy-core's
# integer forward pass on the same integer actor, in one program under the same QEMU, counted by
# the same TCG plugin as scripts/cortex-m.sh's variants (docs/cortex-m.md, "CMSIS-NN beside the
# SMLAD kernel").
#
#   scripts/bench-cmsis-nn.sh CMSIS_NN_DIR [INTEGER_BLOB]
#
# CMSIS_NN_DIR is a checkout of github.com/ARM-software/CMSIS-NN, kept outside this repository
# (it needs no other CMSIS package: its Include/ carries the compiler intrinsics). INTEGER_BLOB
# defaults to models/nav-walls__dcp-paper__0-integer.postcard, what the m4f-trained-integer
# variant runs. The toolchain is scripts/cortex-m.sh's (`bash scripts/cortex-m.sh
# --install-only`): rustc-web for policy-core's C API library, arm-none-eabi-gcc, QEMU.
#
# Steps: `studies --bin cmsis-nn-header` writes the actor in CMSIS-NN's layout with the host's
# codes; policy-core-ffi is built for thumbv7em-none-eabihf as cortex-m.sh builds it (the same
# cache); CMSIS-NN's two files the pass calls are compiled as CMSIS-NN's CMake builds them
# (-Ofast, ARM_MATH_DSP from -mcpu=cortex-m4); firmware-c/cmsis-nn/main.c runs both passes on
# every case under QEMU's mps2-an386. Prints a table; exits 1 if either pass's codes differ from
# the host's, 2 on a usage error.
set -euo pipefail
case $# in 1|2) ;; *) echo "usage: scripts/bench-cmsis-nn.sh CMSIS_NN_DIR [INTEGER_BLOB]" >&2; exit 2 ;; esac
cmsis=$(realpath -m "$1")
[ $# -lt 2 ] || set -- "$1" "$(realpath -m "$2")"
cd "$(dirname "$0")/.."
blob=${2:-models/nav-walls__dcp-paper__0-integer.postcard}
[ -f "$cmsis/Include/arm_nnfunctions.h" ] || { echo "bench-cmsis-nn: $cmsis holds no Include/arm_nnfunctions.h: not a CMSIS-NN checkout" >&2; exit 2; }
[ -f "$blob" ] || { echo "bench-cmsis-nn: no blob $blob" >&2; exit 2; }
RUSTC_X=${PREFIX:-/opt/rust-web}/bin/rustc
for tool in "$RUSTC_X" arm-none-eabi-gcc qemu-system-arm gcc; do
  command -v "$tool" >/dev/null || { echo "bench-cmsis-nn: $tool not found: run bash scripts/cortex-m.sh --install-only" >&2; exit 2; }
done
BASE=$(realpath -m "${CARGO_TARGET_DIR:-target}")
WORK=$BASE/cmsis-nn
mkdir -p "$WORK"

# The header: the actor in CMSIS-NN's layout, the blob, the input codes and the host's codes.
cargo run --release -q -p studies --bin cmsis-nn-header -- "$blob" "$WORK/net.h"

# policy-core's C API for the M4F, as scripts/cortex-m.sh's build_c_firmware builds it.
target=thumbv7em-none-eabihf
env -u RUSTFLAGS -u CARGO_ENCODED_RUSTFLAGS -u CARGO_BUILD_RUSTFLAGS RUSTC="$RUSTC_X" RUSTC_BOOTSTRAP=1 \
  CARGO_TARGET_DIR="$BASE/cortex-m/ffi" CARGO_RESOLVER_FEATURE_UNIFICATION=package \
  CARGO_PROFILE_RELEASE_LTO=fat CARGO_PROFILE_RELEASE_CODEGEN_UNITS=1 CARGO_PROFILE_RELEASE_PANIC=abort \
  CARGO_PROFILE_RELEASE_DEBUG=true \
  cargo rustc --release --locked -q -p policy-core-ffi --lib --crate-type staticlib \
  -Zbuild-std=core -Zbuild-std-features=compiler-builtins-mem --target "$target" 2>&1 \
  | { grep -v 'feature-unification' || true; }
lib=$BASE/cortex-m/ffi/$target/release/libpolicy_core_ffi.a

# The plugin, as cortex-m.sh builds it.
plugin=$WORK/libicount.so
gcc -shared -fPIC -O2 -Wall -o "$plugin" firmware/qemu-plugin/icount.c

# CMSIS-NN with its CMake's flags (CMSIS_OPTIMIZATION_LEVEL -Ofast, no -ffreestanding: its
# 4-byte reads are memcpy calls the compiler turns into single loads; the toolchain has no C
# library, so firmware-c/cmsis-nn/libc/string.h declares them); the program with the same flags,
# since arm_nn_requantize is inline; startup and console as the example C firmware's.
cpu=(-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16)
nn_flags=(-Ofast -g -ffunction-sections -fdata-sections -I firmware-c/cmsis-nn/libc -I "$cmsis/Include")
c_flags=(-std=c11 -O2 -g -Wall -Wextra -Werror -ffreestanding -ffunction-sections -fdata-sections)
objs=()
for src in Source/FullyConnectedFunctions/arm_fully_connected_per_channel_s8.c \
           Source/NNSupportFunctions/arm_nn_vec_mat_mult_t_per_ch_s8.c; do
  obj=$WORK/$(basename "$src" .c).o
  arm-none-eabi-gcc "${cpu[@]}" "${nn_flags[@]}" -c "$cmsis/$src" -o "$obj"
  objs+=("$obj")
done
arm-none-eabi-gcc "${cpu[@]}" "${nn_flags[@]}" -Wall -Wextra -Werror -I "$WORK" -I firmware-c \
  -I policy-core-ffi/include -c firmware-c/cmsis-nn/main.c -o "$WORK/main.o"
for src in startup console; do
  arm-none-eabi-gcc "${cpu[@]}" "${c_flags[@]}" -c "firmware-c/$src.c" -o "$WORK/$src.o"
done
arm-none-eabi-gcc "${cpu[@]}" -nostdlib -Wl,--gc-sections -Wl,-z,noexecstack -L firmware/mps2 \
  -T firmware-c/link.ld "$WORK"/{main,startup,console}.o "${objs[@]}" "$lib" -lgcc -o "$WORK/bench.elf"

mark=$(arm-none-eabi-nm "$WORK/bench.elf" | awk '$3=="fw_mark"{print $1}')
status=0
timeout 120 qemu-system-arm -nographic -semihosting-config enable=on,target=native -icount shift=0 \
  -M mps2-an386 -cpu cortex-m4 -plugin "$plugin,mark=$(printf '0x%x' $((0x$mark & ~1)))" -d plugin \
  -kernel "$WORK/bench.elf" </dev/null >"$WORK/firmware.log" 2>"$WORK/plugin.log" || status=$?
grep -E '^(MISMATCH|FAIL)' "$WORK/firmware.log" >&2 || true
if [ "$status" != 0 ] || ! grep -qx 'DONE bit-exact' "$WORK/firmware.log"; then
  echo "bench-cmsis-nn: not bit-exact, or the run failed (QEMU status $status; $WORK/firmware.log)" >&2
  tail -n 5 "$WORK/firmware.log" "$WORK/plugin.log" >&2
  exit 1
fi

macs=$(sed -n 's/^#define NET_MACS //p' "$WORK/net.h")
outputs=$(sed -n 's/^#define NET_OUTPUTS //p' "$WORK/net.h")
cases=$(sed -n 's/^#define NET_CASES //p' "$WORK/net.h")
nn_commit=$(git -C "$cmsis" rev-parse --short HEAD 2>/dev/null || echo "not a git checkout")
sed -n 's/^PLUGIN_MARK //p' "$WORK/plugin.log" | awk -v macs="$macs" -v outputs="$outputs" \
    -v cases="$cases" -v blob="$blob" -v nn="$nn_commit" '
  { m[n++] = $1 }
  END {
    if (n != 4 * cases + 4) { printf "bench-cmsis-nn: expected %d marks, found %d\n", 4 * cases + 4, n > "/dev/stderr"; exit 1 }
    ovh = m[1] - m[0]
    for (k = 0; k < cases; k++) {
      t = m[3 + 4 * k] - m[2 + 4 * k] - ovh; o = m[5 + 4 * k] - m[4 + 4 * k] - ovh
      ts += t; os += o; if (t > tmax) tmax = t; if (o > omax) omax = o
    }
    tm = ts / cases; om = os / cases; req = m[3 + 4 * cases] - m[2 + 4 * cases] - ovh
    printf "%s, %d MACs, %d outputs requantised, %d cases, every code bit-exact with the host\n\n", blob, macs, outputs, cases
    print "| pass (Cortex-M4F, mps2-an386) | instr/act mean (max) | instr/MAC |"
    print "|---|---:|---:|"
    printf "| CMSIS-NN %s, arm_fully_connected_per_channel_s8 (-Ofast) | %.1f (%d) | %.3f |\n", nn, tm, tmax, tm / macs
    printf "| ours: dcp_act_codes (policy-core, release) | %.1f (%d) | %.3f |\n", om, omax, om / macs
    printf "\nours / CMSIS-NN = %.3f (mean over mean)\n", om / tm
    printf "CMSIS-NN requantisation alone (arm_nn_requantize, offset, clamp, store; every output once): %d instructions, %.1f per output; the rest of its act %.1f, %.3f per MAC\n", req, req / outputs, tm - req, (tm - req) / macs
  }'
