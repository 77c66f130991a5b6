#!/usr/bin/env bash
# c-dist.sh -- policy-core's C API as a release folder a C team adds without a Rust toolchain:
# a static archive per Cortex-M core, the header, a CMake package with an imported target, a
# pkg-config file per core, a version file and the licenses, laid out as TFLM and CMSIS-NN ship
# theirs:
#
#   policy-core-VERSION/
#     include/policy_core.h
#     lib/cortex-m0/libpolicy_core.a      thumbv6m-none-eabi     (Cortex-M0, M0+, M1)
#     lib/cortex-m3/libpolicy_core.a      thumbv7m-none-eabi     (Cortex-M3, soft float)
#     lib/cortex-m4f/libpolicy_core.a     thumbv7em-none-eabihf  (Cortex-M4F, M7: hard float)
#     lib/cmake/policy_core/policy_coreConfig.cmake, policy_coreConfigVersion.cmake
#     lib/pkgconfig/policy_core-CORE.pc
#     VERSION, SHA256SUMS, LICENSE-MIT, LICENSE-APACHE
#
# Each archive is policy-core-ffi built as cortex-m.sh builds the C firmware's (release, fat LTO,
# one codegen unit, panic = abort, `core` and compiler_builtins' memcpy/memset from source; debug
# info stripped), with
# the compiler pinned in firmware/budgets.txt (`bash scripts/cortex-m.sh --install-only`
# installs it). Then, unless --no-check, the folder is used as a C team would, with no Rust
# involved: the example C firmware (firmware-c/) is configured with CMake (`find_package
# (policy_core)`) for the M4F and compiled with `pkg-config`'s flags for the M3, a program that
# boots and acts is linked for the M0 the same way, and the M4F firmware runs under QEMU on a
# blob, its actions checked bit for bit against policy-core.
#
# Usage: bash scripts/c-dist.sh [--out DIR] [--no-check]
#   --out DIR     where the release folder goes (default: <target dir>/c-dist).
#   --no-check    build the folder only.
# Environment: PREFIX (the compiler prefix, default /opt/rust-web), CARGO_TARGET_DIR.
# Exit status: 0 = every archive built (and, with the check, every example built and the M4F one
# bit-exact with the host).
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
[ -n "$VERSION" ] && [ -n "$ABI" ] || die "expected the workspace version and DCP_ABI_VERSION, found '$VERSION' and '$ABI'"
DIST=$OUT/policy-core-$VERSION
# core name : Rust target : GCC flags
CORES=(
  "cortex-m0:thumbv6m-none-eabi:-mcpu=cortex-m0 -mthumb -mfloat-abi=soft"
  "cortex-m3:thumbv7m-none-eabi:-mcpu=cortex-m3 -mthumb -mfloat-abi=soft"
  "cortex-m4f:thumbv7em-none-eabihf:-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16"
)
# cortex-m.sh's settings and build folder for the C firmware's library, so that after it (as in
# CI) the M3 and M4F archives are already built; the copies here are stripped of debug info.
FFI_DIR=$BASE/cortex-m/ffi
FFI_ENV=(env -u RUSTFLAGS -u CARGO_ENCODED_RUSTFLAGS -u CARGO_BUILD_RUSTFLAGS RUSTC="$RUSTC_X" RUSTC_BOOTSTRAP=1
  CARGO_TARGET_DIR="$FFI_DIR" CARGO_RESOLVER_FEATURE_UNIFICATION=package
  CARGO_PROFILE_RELEASE_LTO=fat CARGO_PROFILE_RELEASE_CODEGEN_UNITS=1 CARGO_PROFILE_RELEASE_PANIC=abort
  CARGO_PROFILE_RELEASE_DEBUG=true)

rm -rf "$DIST"; mkdir -p "$DIST/include" "$DIST/lib/cmake/policy_core" "$DIST/lib/pkgconfig"
cp "$ROOT/policy-core-ffi/include/policy_core.h" "$DIST/include/"
cp "$ROOT/LICENSE-MIT" "$ROOT/LICENSE-APACHE" "$DIST/"
for spec in "${CORES[@]}"; do
  IFS=: read -r core target cflags <<<"$spec"
  echo "=== $core: policy-core-ffi for $target"
  (cd "$ROOT" && "${FFI_ENV[@]}" cargo rustc --release --locked -q -p policy-core-ffi --lib --crate-type staticlib \
      -Zbuild-std=core -Zbuild-std-features=compiler-builtins-mem --target "$target") \
    || die "$core: cargo could not build policy-core-ffi for $target"
  mkdir -p "$DIST/lib/$core"
  arm-none-eabi-strip --strip-debug -o "$DIST/lib/$core/libpolicy_core.a" "$FFI_DIR/$target/release/libpolicy_core_ffi.a"
  cat > "$DIST/lib/pkgconfig/policy_core-$core.pc" <<EOF
# policy-core's C API for the $core ($target; compile with: $cflags).
prefix=\${pcfiledir}/../..
includedir=\${prefix}/include
libdir=\${prefix}/lib/$core

Name: policy_core-$core
Description: Verify a DCP policy blob, load it from flash, act, choose an A/B slot (C API, ABI $ABI)
Version: $VERSION
Cflags: -I\${includedir}
Libs: -L\${libdir} -lpolicy_core
EOF
done

cat > "$DIST/lib/cmake/policy_core/policy_coreConfig.cmake" <<'EOF'
# find_package(policy_core) for a firmware: the imported target policy_core::policy_core (the
# header's folder and the archive of one core). Set POLICY_CORE_CORE to cortex-m0, cortex-m3 or
# cortex-m4f before find_package; compile with that core's flags (policy_core-CORE.pc says which).
get_filename_component(_policy_core_root "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
file(GLOB _policy_core_cores RELATIVE "${_policy_core_root}/lib" "${_policy_core_root}/lib/cortex-*")
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
endif()
set(policy_core_FOUND TRUE)
EOF
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
rustc $RELEASE (Debian rustc-web $PIN_DEBIAN, LLVM $LLVM), -Zbuild-std=core, fat LTO, panic = abort, debug info stripped
EOF
(cd "$DIST" && find . -type f ! -name SHA256SUMS | sort | xargs sha256sum > SHA256SUMS)
echo "release folder: $DIST"
[ "$CHECK" = 1 ] || exit 0

#--------------------------------------------------------------------------------------------------
# The folder as a C team uses it: CMake for the M4F, pkg-config for the M3 and M0, no Rust.
command -v cmake >/dev/null || die "expected cmake on PATH for the check (apt-get install cmake), found none"
command -v pkg-config >/dev/null || die "expected pkg-config on PATH for the check, found none"
EX=$OUT/example; rm -rf "$EX"; mkdir -p "$EX"
echo "=== cortex-m4f: the example C firmware with CMake, find_package(policy_core)"
cmake -S "$ROOT/examples/c-cmake" -B "$EX/m4f" -DCMAKE_TOOLCHAIN_FILE="$ROOT/examples/c-cmake/arm-none-eabi.cmake" \
  -DCMAKE_PREFIX_PATH="$DIST" -DPOLICY_CORE_CORE=cortex-m4f -DREPO="$ROOT" >"$EX/m4f.log" 2>&1 \
  && cmake --build "$EX/m4f" >>"$EX/m4f.log" 2>&1 || { tail -20 "$EX/m4f.log"; die "cortex-m4f: the CMake example did not build"; }
# The M3 builds the example firmware; the M0 (Thumb-1: the example's calibration loop is Thumb-2
# assembly) links the header's own test program (a boot and an act) against its archive.
pkgflags() { PKG_CONFIG_PATH="$DIST/lib/pkgconfig" pkg-config --cflags --libs "policy_core-$1"; }
M3_FLAGS=(-mcpu=cortex-m3 -mthumb -mfloat-abi=soft); M0_FLAGS=(-mcpu=cortex-m0 -mthumb -mfloat-abi=soft)
echo "=== cortex-m3: the example C firmware with pkg-config --cflags --libs policy_core-cortex-m3"
# shellcheck disable=SC2046 # pkg-config's output is a list of flags
arm-none-eabi-gcc "${M3_FLAGS[@]}" -std=c11 -O2 -Wall -Wextra -Werror -ffreestanding -ffunction-sections -fdata-sections \
  -nostdlib -Wl,--gc-sections -Wl,-z,noexecstack -L "$ROOT/firmware" -T "$ROOT/firmware-c/link.ld" \
  "$ROOT"/firmware-c/{main,startup,console}.c $(pkgflags cortex-m3) -lgcc -o "$EX/cortex-m3.elf" \
  || die "cortex-m3: the example did not build with pkg-config's flags"
echo "=== cortex-m0: a boot and an act (policy-core-ffi/tests/c/c89.c) linked with pkg-config --cflags --libs policy_core-cortex-m0"
# shellcheck disable=SC2046
arm-none-eabi-gcc "${M0_FLAGS[@]}" -std=c89 -pedantic -O2 -Wall -Wextra -Werror -ffreestanding -ffunction-sections \
  -fdata-sections -nostdlib -Wl,--gc-sections -Wl,-z,noexecstack -Wl,--entry=c89_boot "$ROOT/policy-core-ffi/tests/c/c89.c" \
  $(pkgflags cortex-m0) -lgcc -o "$EX/cortex-m0.elf" \
  || die "cortex-m0: a program did not link with pkg-config's flags"
nm "$EX/cortex-m0.elf" | grep -q ' T dcp_act$' || die "cortex-m0: expected dcp_act in the linked program, found none"

echo "=== cortex-m4f: the CMake-built firmware under QEMU on the trained blob, checked against the host"
HC_DIR=$BASE/cortex-m/host
(cd "$ROOT" && env -u RUSTC -u RUSTC_BOOTSTRAP -u RUSTFLAGS CARGO_TARGET_DIR="$HC_DIR" \
  cargo build --release --locked -q --manifest-path firmware/host-check/Cargo.toml)
HC=$HC_DIR/release/host-check
BLOB=$ROOT/models/nav-walls__dcp-paper__0.postcard
ELF=$EX/m4f/firmware.elf
"$HC" image "$BLOB" "$EX/slot-a.bin" --sequence 1 >/dev/null
SLOT_A=0x$(nm "$ELF" | awk '$3=="_slot_a"{print $1}')
timeout 60 qemu-system-arm -M mps2-an386 -cpu cortex-m4 -nographic -semihosting-config enable=on,target=native \
  -device "loader,file=$EX/slot-a.bin,addr=$SLOT_A" -kernel "$ELF" </dev/null >"$EX/m4f-firmware.log" 2>&1 \
  || { tail -5 "$EX/m4f-firmware.log"; die "cortex-m4f: the CMake-built firmware failed under QEMU"; }
"$HC" check "$BLOB" "$EX/m4f-firmware.log" | tail -1
echo "RESULT: PASS ($DIST: ${#CORES[@]} archives; the example built with CMake and pkg-config, bit-exact on the M4F)"
