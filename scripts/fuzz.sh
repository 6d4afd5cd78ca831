#!/usr/bin/env bash
# Runs every fuzz target (tests/fuzz/targets) under libFuzzer with ASan + UBSan for a
# bounded time each, starting from the committed corpus, and prints per target the
# executions, the time and the findings. Needs clang with libFuzzer (Debian: clang,
# libclang-rt-14-dev). A finding's input lands in build-fuzz/findings/<target>/; once the
# bug is fixed, copy it into tests/fuzz/corpus/<target>/ so every test run replays it.
# Usage: scripts/fuzz.sh [SECONDS_PER_TARGET (default 10)] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-10}
shift || true
command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (apt-get install clang libclang-rt-14-dev)"; exit 2; }
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for f in tests/fuzz/targets/*.cpp; do targets+=("$(basename "$f" .cpp)"); done
fi
CC=clang CXX=clang++ cmake -S tests/fuzz -B build-fuzz -G Ninja >/dev/null
cmake --build build-fuzz --parallel "$(nproc)" --target "${targets[@]/#/fuzz_}" >build-fuzz/build.log 2>&1 ||
  { tail -30 build-fuzz/build.log; echo "fuzz.sh: the fuzz build failed (build-fuzz/build.log)"; exit 2; }
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0:allocator_may_return_null=0:malloc_limit_mb=2048}
printf '%-12s %12s %8s %9s\n' target executions seconds findings
total_findings=0
for t in "${targets[@]}"; do
  work=build-fuzz/corpus/$t findings=build-fuzz/findings/$t
  mkdir -p "$work" "$findings"
  seeds=("tests/fuzz/corpus/$t")
  [ "$t" = pickle ] && seeds+=(tests/fixtures/pickle)
  for s in "${seeds[@]}"; do [ -d "$s" ] && cp -n "$s"/* "$work"/ 2>/dev/null || true; done
  log=build-fuzz/$t.log
  set +e
  "build-fuzz/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len=262144 \
    -print_final_stats=1 -artifact_prefix="$findings/" "$work" >"$log" 2>&1
  set -e
  execs=$(grep -o 'stat::number_of_executed_units: [0-9]*' "$log" | awk '{print $2}' | tail -1)
  n=$(find "$findings" -type f | wc -l)
  total_findings=$((total_findings + n))
  printf '%-12s %12s %8s %9s\n' "$t" "${execs:-?}" "$seconds" "$n"
done
[ "$total_findings" -eq 0 ] || { echo "fuzz.sh: $total_findings finding(s) under build-fuzz/findings (logs: build-fuzz/*.log)"; exit 1; }
