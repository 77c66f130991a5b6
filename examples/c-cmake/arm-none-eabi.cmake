# A CMake toolchain file for a Cortex-M with Debian's GNU Arm toolchain (gcc-arm-none-eabi):
# freestanding, no C library, the compile flags of the release folder's core POLICY_CORE_CORE
# (default cortex-m4f), as its lib/pkgconfig/policy_core-CORE.pc names them.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES POLICY_CORE_CORE)
if(NOT POLICY_CORE_CORE)
  set(POLICY_CORE_CORE cortex-m4f)
endif()
set(_flags_cortex-m0 "-mcpu=cortex-m0 -mthumb -mfloat-abi=soft")
set(_flags_cortex-m3 "-mcpu=cortex-m3 -mthumb -mfloat-abi=soft")
set(_flags_cortex-m4 "-mcpu=cortex-m4 -mthumb -mfloat-abi=soft")
set(_flags_cortex-m4f "-mcpu=cortex-m4 -mthumb -mfloat-abi=hard -mfpu=fpv4-sp-d16")
set(_flags_cortex-m33 "-mcpu=cortex-m33 -mthumb -mfloat-abi=hard -mfpu=fpv5-sp-d16")
if(NOT DEFINED _flags_${POLICY_CORE_CORE})
  message(FATAL_ERROR "expected POLICY_CORE_CORE to be a Cortex-M core (cortex-m0, cortex-m3, "
    "cortex-m4, cortex-m4f, cortex-m33), found ${POLICY_CORE_CORE}")
endif()
string(REGEX REPLACE "^-mcpu=([^ ]*).*" "\\1" CMAKE_SYSTEM_PROCESSOR "${_flags_${POLICY_CORE_CORE}}")
set(CMAKE_C_FLAGS_INIT "${_flags_${POLICY_CORE_CORE}}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
