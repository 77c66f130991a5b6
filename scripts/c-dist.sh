#!/usr/bin/env bash
# c-dist.sh -- policy-core's C API as a release folder a C team adds without a Rust toolchain:
# a static archive per Cortex-M core and one for the host, the header, a CMake package with an
# imported target, a pkg-config file per core, a version file and the licenses, laid out as TFLM
# and CMSIS-NN ship theirs:
#
#   policy-core-VERSION/
#     include/policy_core.h
#     lib/cortex-m0/libpolicy_core.a         thumbv6m-none-eabi         (Cortex-M0, M0+, M1)
#     lib/cortex-m3/libpolicy_core.a         thumbv7m-none-eabi         (Cortex-M3, soft float)
#     lib/cortex-m4/libpolicy_core.a         thumbv7em-none-eabi        (Cortex-M4, M7: soft float)
#     lib/cortex-m4f/libpolicy_core.a        thumbv7em-none-eabihf      (Cortex-M4F, M7: hard float)
#     lib/cortex-m33/libpolicy_core.a        thumbv8m.main-none-eabihf  (Cortex-M33, M35P: hard float)
#     lib/x86_64-linux-gnu/libpolicy_core.a  the host's target, with Rust's std (a PC's tests)
#     lib/cmake/policy_core/policy_coreConfig.cmake, policy_coreConfigVersion.cmake
#     lib/pkgconfig/policy_core-CORE.pc
#     VERSION, SHA256SUMS, LICENSE-MIT, LICENSE-APACHE
#
# Each Cortex-M archive is policy-core-ffi built as cortex-m.sh builds the C firmware's (release,
# fat LTO, one codegen unit, panic = abort, `core` and compiler_builtins' memcpy/memset from
# source; debug info stripped), with the compiler pinned in firmware/budgets.txt (`bash
# scripts/cortex-m.sh --install-only` installs it). The host archive is built the same way by
# the rustup toolchain, with its prebuilt std, for the machine's own target and its baseline CPU
# (the folder is named for it: x86_64-linux-gnu on CI); its pkg-config file and the CMake target
# name the system libraries std needs, as rustc prints them (--print native-static-libs).
#
# Then, unless --no-check, the folder is used as a C team would, with no Rust involved: the
# example C firmware (firmware-c/) is configured with CMake (`find_package(policy_core)`) for the
# M4F, M4 and M33 and compiled with `pkg-config`'s flags for the M3 and the M0, and each of the
# five runs under QEMU on a blob, its actions checked bit for bit against policy-core (M0:
# microbit, M3: mps2-an385, M4 and M4F: mps2-an386, M33: mps2-an505); a C89 program that boots
# and acts is linked for every Cortex-M core with its pkg-config flags; and a host C program
# (examples/c-host-cmake/) is built with CMake and with pkg-config and run on three blobs, its
# actions compared bit for bit with `host-trainer act`'s.
#
# Usage: bash scripts/c-dist.sh [--out DIR] [--no-check]
#   --out DIR     where the release folder goes (default: <target dir>/c-dist).
#   --no-check    build the folder only.
# Environment: PREFIX (the compiler prefix, default /opt/rust-web), CARGO_TARGET_DIR, CC (the
# host C compiler, default cc).
# Exit status: 0 = every archive built (and, with the check, every example built, the five
# firmwares and the host program bit-exact with the host's policy-core).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PREFIX=${PREFIX:-/opt/rust-web}
BASE=$(realpath -m "${CARGO_TARGET_DIR:-$ROOT/target}")
OUT=$BASE/c-dist
CHECK=1
die() { echo "c-dist.sh: error: $*" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case $1 in
    --out) [ $# -ge 2 ] || die "--out needs a folder"; OUT=$(realpath -m "$2"); shift 2 ;;
    --no-check) CHECK=0; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) die "unknown argument $1 (see --help)" ;;
  esac
done

RUSTC_X=$PREFIX/bin/rustc
[ -x "$RUSTC_X" ] || die "expected the compiler at $RUSTC_X, found none: run bash scripts/cortex-m.sh --install-only"
read -r _ _ PIN_DEBIAN _ PIN_RELEASE _ PIN_LLVM < <(grep -m1 '^toolchain ' "$ROOT/firmware/budgets.txt")
RELEASE=$("$RUSTC_X" -vV | sed -n 's/^release: //p'); LLVM=$("$RUSTC_X" -vV | sed -n 's/^LLVM version: //p')
[ "$RELEASE $LLVM" = "$PIN_RELEASE $PIN_LLVM" ] \
  || die "expected rustc $PIN_RELEASE with LLVM $PIN_LLVM (firmware/budgets.txt), found rustc $RELEASE with LLVM $LLVM"

VERSION=$(sed -n 's/^version = "\(.*\)"/\1/p' "$ROOT/Cargo.toml" | head -1)
ABI=$(sed -n 's/^#define DCP_ABI_VERSION \([0-9]*\)$/\1/p' "$ROOT/policy-core-ffi/include/policy_core.h")
{ [ -n "$VERSION" ] && [ -n "$ABI" ]; } || die "expected the workspace version and DCP_ABI_VERSION, found '$VERSION' and '$ABI'"
DIST=$OUT/policy-core-$VERSION
# core name : Rust target : GCC flags
CORES=(
  "cortex-m0:thumbv6m-none-eabi:-mcpu=cortex-m0 -mthumb -mfloat-abi=soft"
  "cortex-m3:thumbv7m-none-eabi:-mcpu=cortex-m3 -mthumb -mfloat-abi=soft"
  "cortex-m4:thumbv7em-none-eabi:-mcpu=cortex-m4 -mthumb -mfloat-abi=soft"
  "cortex-m4f:thumbv7em-none-eabihf:-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16"
  "cortex-m33:thumbv8m.main-none-eabihf:-mcpu=cortex-m33 -mthumb -mfloat-abi=hard -mfpu=fpv5-sp-d16"
)
# The host archive: the rustup toolchain's own target (the toolchain the workspace's tests use),
# its folder named without the vendor (x86_64-unknown-linux-gnu: x86_64-linux-gnu).
HOST_VV=$(cd "$ROOT" && env -u RUSTC -u RUSTC_BOOTSTRAP rustc -vV) || die "expected rustup's rustc on PATH, found none"
HOST_TARGET=$(sed -n 's/^host: //p' <<<"$HOST_VV"); HOST_RELEASE=$(sed -n 's/^release: //p' <<<"$HOST_VV")
HOST_CORE=${HOST_TARGET/-unknown-/-}
# cortex-m.sh's settings and build folder for the C firmware's library, so that after it (as in
# CI) the M3 and M4F archives are already built; the copies here are stripped of debug info.
FFI_DIR=$BASE/cortex-m/ffi
PROFILE_ENV=(CARGO_TARGET_DIR="$FFI_DIR" CARGO_RESOLVER_FEATURE_UNIFICATION=package
  CARGO_PROFILE_RELEASE_LTO=fat CARGO_PROFILE_RELEASE_CODEGEN_UNITS=1 CARGO_PROFILE_RELEASE_PANIC=abort
  CARGO_PROFILE_RELEASE_DEBUG=true)
FFI_ENV=(env -u RUSTFLAGS -u CARGO_ENCODED_RUSTFLAGS -u CARGO_BUILD_RUSTFLAGS RUSTC="$RUSTC_X" RUSTC_BOOTSTRAP=1
  "${PROFILE_ENV[@]}")
# RUSTFLAGS set and empty: not the workspace's x86-64-v3 (.cargo/config.toml, for the trainer's
# kernels), so that the archive runs on any x86-64; policy-core asks for no fused multiply-add,
# and the check below compares it with host-trainer's v3 build bit for bit.
HOST_ENV=(env -u CARGO_ENCODED_RUSTFLAGS -u CARGO_BUILD_RUSTFLAGS -u RUSTC -u RUSTC_BOOTSTRAP RUSTFLAGS=
  "${PROFILE_ENV[@]}")
T0=$SECONDS

# pcfile CORE DESCRIPTION LIBS: the core's pkg-config file, relocatable through ${pcfiledir}.
pcfile() {
  cat > "$DIST/lib/pkgconfig/policy_core-$1.pc" <<EOF
# policy-core's C API for $1 ($2).
prefix=\${pcfiledir}/../..
includedir=\${prefix}/include
libdir=\${prefix}/lib/$1

Name: policy_core-$1
Description: Verify a DCP policy blob, load it from flash, act, choose an A/B slot (C API, ABI $ABI)
Version: $VERSION
Cflags: -I\${includedir}
Libs: -L\${libdir} -lpolicy_core$3
EOF
}

rm -rf "$DIST"; mkdir -p "$DIST/include" "$DIST/lib/cmake/policy_core" "$DIST/lib/pkgconfig"
cp "$ROOT/policy-core-ffi/include/policy_core.h" "$DIST/include/"
cp "$ROOT/LICENSE-MIT" "$ROOT/LICENSE-APACHE" "$DIST/"
for spec in "${CORES[@]}"; do
  IFS=: read -r core target cflags <<<"$spec"
  echo "=== $core: policy-core-ffi for $target"
  t=$SECONDS
  (cd "$ROOT" && "${FFI_ENV[@]}" cargo rustc --release --locked -q -p policy-core-ffi --lib --crate-type staticlib \
      -Zbuild-std=core -Zbuild-std-features=compiler-builtins-mem --target "$target") \
    || die "$core: cargo could not build policy-core-ffi for $target"
  echo "    $((SECONDS - t)) s"
  mkdir -p "$DIST/lib/$core"
  arm-none-eabi-strip --strip-debug -o "$DIST/lib/$core/libpolicy_core.a" "$FFI_DIR/$target/release/libpolicy_core_ffi.a"
  pcfile "$core" "$target; compile with: $cflags" ""
done

echo "=== $HOST_CORE: policy-core-ffi for $HOST_TARGET (rustup's rustc $HOST_RELEASE, its prebuilt std)"
t=$SECONDS
# Not quiet: cargo replays rustc's notes when the archive is already built, and one of them
# names the system libraries the archive needs.
HOST_LOG=$OUT/host-build.log; mkdir -p "$OUT"
(cd "$ROOT" && "${HOST_ENV[@]}" cargo rustc --release --locked -p policy-core-ffi --lib --crate-type staticlib \
    --target "$HOST_TARGET" -- --print native-static-libs) >"$HOST_LOG" 2>&1 \
  || { tail -20 "$HOST_LOG"; die "$HOST_CORE: cargo could not build policy-core-ffi for $HOST_TARGET"; }
echo "    $((SECONDS - t)) s"
# The C compiler driver adds -lc itself.
read -r -a HOST_LIBS <<<"$(sed -n 's/^note: native-static-libs: //p' "$HOST_LOG" | tail -1 | tr ' ' '\n' | grep -vx -- -lc | tr '\n' ' ')"
[ "${#HOST_LIBS[@]}" -gt 0 ] || die "$HOST_CORE: expected rustc's native-static-libs note in $HOST_LOG, found none"
for lib in "${HOST_LIBS[@]}"; do
  [[ $lib == -l* ]] || die "$HOST_CORE: expected -lNAME in rustc's native-static-libs, found $lib"
done
mkdir -p "$DIST/lib/$HOST_CORE"
strip --strip-debug -o "$DIST/lib/$HOST_CORE/libpolicy_core.a" "$FFI_DIR/$HOST_TARGET/release/libpolicy_core_ffi.a"
pcfile "$HOST_CORE" "$HOST_TARGET, baseline CPU, with Rust's std: Libs names the system libraries std needs" \
  " ${HOST_LIBS[*]}"
CORE_NAMES=$(for spec in "${CORES[@]}"; do printf '%s, ' "${spec%%:*}"; done)$HOST_CORE

cat > "$DIST/lib/cmake/policy_core/policy_coreConfig.cmake" <<'EOF'
# find_package(policy_core): the imported target policy_core::policy_core (the header's folder,
# the archive of one core, and the system libraries that archive needs). Set POLICY_CORE_CORE
# before find_package to one of
#   @CORES@
# and compile with that core's flags (policy_core-CORE.pc says which).
get_filename_component(_policy_core_root "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
set(_policy_core_cores "@CORES@")
# The host archive holds Rust's std, which links these (rustc --print native-static-libs); the
# Cortex-M archives need none (a firmware links libgcc, as the example does).
set(_policy_core_system_libs_@HOST_CORE@ @HOST_LIBS@)
if(NOT DEFINED POLICY_CORE_CORE)
  set(policy_core_FOUND FALSE)
  set(policy_core_NOT_FOUND_MESSAGE "expected POLICY_CORE_CORE (one of: ${_policy_core_cores}), found none")
  return()
endif()
set(_policy_core_lib "${_policy_core_root}/lib/${POLICY_CORE_CORE}/libpolicy_core.a")
if(NOT EXISTS "${_policy_core_lib}")
  set(policy_core_FOUND FALSE)
  set(policy_core_NOT_FOUND_MESSAGE "expected POLICY_CORE_CORE to be one of: ${_policy_core_cores}, found ${POLICY_CORE_CORE}")
  return()
endif()
if(NOT TARGET policy_core::policy_core)
  add_library(policy_core::policy_core STATIC IMPORTED)
  set_target_properties(policy_core::policy_core PROPERTIES
    IMPORTED_LOCATION "${_policy_core_lib}"
    INTERFACE_INCLUDE_DIRECTORIES "${_policy_core_root}/include")
  if(DEFINED _policy_core_system_libs_${POLICY_CORE_CORE})
    set_target_properties(policy_core::policy_core PROPERTIES
      INTERFACE_LINK_LIBRARIES "${_policy_core_system_libs_${POLICY_CORE_CORE}}")
  endif()
endif()
set(policy_core_FOUND TRUE)
EOF
sed -i -e "s|@CORES@|$CORE_NAMES|g" -e "s|@HOST_CORE@|$HOST_CORE|" -e "s|@HOST_LIBS@|${HOST_LIBS[*]#-l}|" \
  "$DIST/lib/cmake/policy_core/policy_coreConfig.cmake"
cat > "$DIST/lib/cmake/policy_core/policy_coreConfigVersion.cmake" <<EOF
# Compatible when the version asked for is not newer and has the same major version (for 0.x,
# the same minor: 0.x releases may change the ABI; DCP_ABI_CHECK refuses a mismatch at boot).
set(PACKAGE_VERSION "$VERSION")
set(PACKAGE_VERSION_COMPATIBLE FALSE)
if(NOT PACKAGE_FIND_VERSION VERSION_GREATER PACKAGE_VERSION)
  if("$VERSION" MATCHES "^0\\\\." AND PACKAGE_FIND_VERSION_MAJOR EQUAL 0)
    if(PACKAGE_FIND_VERSION_MINOR EQUAL "$(echo "$VERSION" | cut -d. -f2)")
      set(PACKAGE_VERSION_COMPATIBLE TRUE)
    endif()
  elseif(PACKAGE_FIND_VERSION_MAJOR EQUAL "$(echo "$VERSION" | cut -d. -f1)")
    set(PACKAGE_VERSION_COMPATIBLE TRUE)
  endif()
endif()
if(PACKAGE_FIND_VERSION STREQUAL PACKAGE_VERSION)
  set(PACKAGE_VERSION_EXACT TRUE)
endif()
EOF
COMMIT=$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)
DIRTY=$(git -C "$ROOT" status --porcelain 2>/dev/null | grep -q . && echo " (with uncommitted changes)" || true)
cat > "$DIST/VERSION" <<EOF
policy-core C API $VERSION, ABI version $ABI
commit $COMMIT$DIRTY
Cortex-M archives: rustc $RELEASE (Debian rustc-web $PIN_DEBIAN, LLVM $LLVM), -Zbuild-std=core, fat LTO, panic = abort, debug info stripped
$HOST_CORE archive: $HOST_TARGET, rustc $HOST_RELEASE (rustup) with its std, baseline CPU, fat LTO, panic = abort, debug info stripped; links with ${HOST_LIBS[*]}
EOF
(cd "$DIST" && find . -type f ! -name SHA256SUMS | sort | xargs sha256sum > SHA256SUMS)
echo "release folder: $DIST"
[ "$CHECK" = 1 ] || exit 0

#--------------------------------------------------------------------------------------------------
# The folder as a C team uses it, no Rust: CMake and pkg-config, then the programs run.
command -v cmake >/dev/null || die "expected cmake on PATH for the check (apt-get install cmake), found none"
command -v pkg-config >/dev/null || die "expected pkg-config on PATH for the check, found none"
EX=$OUT/example; rm -rf "$EX"; mkdir -p "$EX"
pkgflags() { PKG_CONFIG_PATH="$DIST/lib/pkgconfig" pkg-config --cflags --libs "policy_core-$1"; }
# cmake_build CORE SOURCE [ARGS...]: configure and build an example against the folder, in $EX/CORE.
cmake_build() {
  local core=$1 src=$2; shift 2
  if ! { cmake -S "$src" -B "$EX/$core" -DCMAKE_PREFIX_PATH="$DIST" -DPOLICY_CORE_CORE="$core" "$@" \
      && cmake --build "$EX/$core"; } >"$EX/$core.log" 2>&1; then
    tail -20 "$EX/$core.log"; die "$core: the CMake example did not build"
  fi
}

# Every Cortex-M archive: the header's own test program (a boot and an act, C89; Thumb-1 suffices,
# so the M0 too) linked with its core's flags and pkg-config's.
for spec in "${CORES[@]}"; do
  IFS=: read -r core _ cflags <<<"$spec"
  echo "=== $core: a boot and an act (policy-core-ffi/tests/c/c89.c) linked with pkg-config --cflags --libs policy_core-$core"
  # shellcheck disable=SC2046,SC2086 # the core's flags and pkg-config's output are lists of flags
  arm-none-eabi-gcc $cflags -std=c89 -pedantic -O2 -Wall -Wextra -Werror -ffreestanding -ffunction-sections \
    -fdata-sections -nostdlib -Wl,--gc-sections -Wl,-z,noexecstack -Wl,--entry=c89_boot "$ROOT/policy-core-ffi/tests/c/c89.c" \
    $(pkgflags "$core") -lgcc -o "$EX/$core-c89.elf" \
    || die "$core: a program did not link with pkg-config's flags"
  nm "$EX/$core-c89.elf" | grep -q ' T dcp_act$' || die "$core: expected dcp_act in the linked program, found none"
done

# The example firmware: with CMake for the M4F, M4 and M33.
TOOLCHAIN=$ROOT/examples/c-cmake/arm-none-eabi.cmake
for core in cortex-m4f cortex-m4 cortex-m33; do
  echo "=== $core: the example C firmware with CMake, find_package(policy_core)"
  memory=(); [ "$core" != cortex-m33 ] || memory=(-DMEMORY_DIR="$ROOT/examples/c-cmake/mps2-an505")
  cmake_build "$core" "$ROOT/examples/c-cmake" -DCMAKE_TOOLCHAIN_FILE="$TOOLCHAIN" -DREPO="$ROOT" "${memory[@]}"
done
# With pkg-config's flags for the M3 and the M0 (the M0 with the microbit's nRF51822 layout: 256 KiB
# of flash, 16 KiB of RAM).
for spec in "cortex-m3:-mcpu=cortex-m3:firmware/mps2" "cortex-m0:-mcpu=cortex-m0:firmware-c/nrf51"; do
  IFS=: read -r core cpu layout <<<"$spec"
  echo "=== $core: the example C firmware with pkg-config --cflags --libs policy_core-$core"
  mkdir -p "$EX/$core"
  # shellcheck disable=SC2046 # pkg-config's output is a list of flags
  arm-none-eabi-gcc "$cpu" -mthumb -mfloat-abi=soft -std=c11 -O2 -Wall -Wextra -Werror -ffreestanding \
    -ffunction-sections -fdata-sections -nostdlib -Wl,--gc-sections -Wl,-z,noexecstack -L "$ROOT/$layout" \
    -T "$ROOT/firmware-c/link.ld" "$ROOT"/firmware-c/{main,startup,console}.c $(pkgflags "$core") -lgcc \
    -o "$EX/$core/firmware.elf" \
    || die "$core: the example did not build with pkg-config's flags"
done

echo "=== the five firmwares under QEMU on the trained blob, checked against policy-core on the host"
HC_DIR=$BASE/cortex-m/host
(cd "$ROOT" && env -u RUSTC -u RUSTC_BOOTSTRAP -u RUSTFLAGS CARGO_TARGET_DIR="$HC_DIR" \
  cargo build --release --locked -q --manifest-path firmware/host-check/Cargo.toml)
HC=$HC_DIR/release/host-check
BLOB=$ROOT/models/nav-walls__dcp-paper__0.postcard
"$HC" image "$BLOB" "$EX/slot-a.bin" --sequence 1 >/dev/null
for run in cortex-m0:microbit:cortex-m0 cortex-m3:mps2-an385:cortex-m3 cortex-m4:mps2-an386:cortex-m4 \
    cortex-m4f:mps2-an386:cortex-m4 cortex-m33:mps2-an505:cortex-m33; do
  IFS=: read -r core machine cpu <<<"$run"
  elf=$EX/$core/firmware.elf; log=$EX/$core-firmware.log
  slot_a=0x$(nm "$elf" | awk '$3=="_slot_a"{print $1}')
  timeout 60 qemu-system-arm -M "$machine" -cpu "$cpu" -nographic -semihosting-config enable=on,target=native \
    -device "loader,file=$EX/slot-a.bin,addr=$slot_a" -kernel "$elf" </dev/null >"$log" 2>&1 \
    || { tail -5 "$log"; die "$core: the firmware failed under QEMU ($machine)"; }
  verdict=$("$HC" check "$BLOB" "$log") || { echo "$verdict" | tail -5; die "$core: the firmware's actions differ from the host's"; }
  echo "$core ($machine): $(tail -1 <<<"$verdict")"
done

echo "=== $HOST_CORE: examples/c-host-cmake with CMake and with pkg-config, checked against host-trainer act"
cmake_build "$HOST_CORE" "$ROOT/examples/c-host-cmake"
# shellcheck disable=SC2046 # pkg-config's output is a list of flags
"${CC:-cc}" -std=c11 -O2 -Wall -Wextra -Werror -pedantic "$ROOT/examples/c-host-cmake/act_check.c" $(pkgflags "$HOST_CORE") \
  -o "$EX/act_check-pkgconfig" || die "$HOST_CORE: the host example did not build with pkg-config's flags"
# The reference: host-trainer (the workspace's own build, as CI's main job left it) on the
# firmware's ten observations, NaN, infinities, -0, a subnormal and f32's extremes included.
(cd "$ROOT" && cargo build --release --locked -q -p host-trainer)
OBS=(--obs "0 0" --obs "1.5 -0.7" --obs "4 -2.5" --obs "-3.2 2.9" --obs "0.37 1.91" --obs "12 -40" --obs "nan 1"
  --obs "inf -inf" --obs "-0 1e-39" --obs "3.4028235e38 -3.4028235e38")
for blob in models/nav-walls__dcp-paper__0.postcard policy-core/tests/golden/actor_2x32.postcard \
    policy-core/tests/golden/actor_4x48_int8.postcard; do
  name=$(basename "$blob" .postcard)
  "$BASE/release/host-trainer" act --blob "$ROOT/$blob" "${OBS[@]}" >"$EX/$name.reference"
  for exe in "$EX/$HOST_CORE/act_check" "$EX/act_check-pkgconfig"; do
    verdict=$("$exe" "$ROOT/$blob" "$EX/$name.reference") \
      || { echo "$verdict" | tail -5; die "$HOST_CORE: $(basename "$exe") on $blob differs from host-trainer act"; }
  done
  echo "$name: $(tail -1 <<<"$verdict")"
done
echo "RESULT: PASS ($DIST: $((${#CORES[@]} + 1)) archives; the firmware bit-exact under QEMU on the M0, M3, M4, M4F and M33," \
  "every Cortex-M archive linked, the host program bit-exact with host-trainer act; $((SECONDS - T0)) s)"
