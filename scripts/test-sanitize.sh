#!/usr/bin/env bash
# Tests built with sanitizers (CUDA off). One command for a developer:
#   bash scripts/test-sanitize.sh [ctest arguments, default: -L "fast|fuzz"]
#     The fast tests and the fuzz corpus replays with AddressSanitizer + UndefinedBehavior-
#     Sanitizer in build-asan/ (a second full build: about 15 minutes on 2 cores).
#     LeakSanitizer runs on the programs that opt in (below), the C API ones.
#   bash scripts/test-sanitize.sh --tsan [ctest arguments, default: -L fast]
#     ThreadSanitizer in build-tsan/, building only the C API tests (tests/runtime/: the
#     code an engine calls from several threads; tests/runtime/runtime_stress_test.cpp).
# Not part of CI.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
mode=asan
if [ "${1:-}" = --tsan ]; then
  mode=tsan
  shift
fi
bash scripts/install-deps.sh
if [ "$mode" = asan ]; then
  dir=build-asan
  flags="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
  link="-fsanitize=address,undefined"
  targets=()  # everything
  default_args=(-L "fast|fuzz")
else
  dir=build-tsan
  flags="-fsanitize=thread -fno-omit-frame-pointer"
  link="-fsanitize=thread"
  targets=(--target test_runtime_runtime_c_api_test test_runtime_runtime_stress_test)
  default_args=(-L fast)
fi
cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DHAHA_WITH_CUDA=OFF \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_C_FLAGS="$flags" \
  -DCMAKE_EXE_LINKER_FLAGS="$link" -DCMAKE_SHARED_LINKER_FLAGS="$link" >/dev/null
cmake --build "$dir" --parallel "$(nproc)" "${targets[@]}"
cd "$dir"
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
# Leak checking is off except for the programs named by a file
# scripts/sanitize/<program>.asan_options (detect_leaks=1; the C API tests): the other
# tests are not yet audited for leaks. include_if_exists reads that file, %b being the
# program's name, after detect_leaks=0 so it wins. scripts/sanitize/lsan.supp suppresses
# only what OpenMP (libgomp) and OpenImageIO keep allocated until exit, never haha code.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:include_if_exists=$root/scripts/sanitize/%b.asan_options}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$root/scripts/sanitize/lsan.supp:print_suppressions=0}
# TSan: the C API tests run their OpenMP loops on one thread (haha_set_num_threads(1)
# under TSan, see runtime_stress_test.cpp): libgomp is not built with TSan, so its barriers
# are invisible to it and its pool threads' writes read as races (false positives).
# OMP_NUM_THREADS=1 does the same for anything else run here.
# scripts/sanitize/tsan.supp: races inside third-party code whose locks TSan cannot see.
export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$root/scripts/sanitize/tsan.supp}
if [ "$mode" = tsan ]; then export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}; fi
if [ $# -eq 0 ]; then set -- "${default_args[@]}"; fi
ctest --output-on-failure -j "$(nproc)" "$@"
