#!/usr/bin/env bash
# The GPU machine's measurements in one call: parity and trainer tests, the
# render benchmark, the paper preset end to end on the GPU, per-kernel times of training
# steps (Nsight Compute), and CPU thread scaling of both presets.
#   scripts/gpu-measure.sh BIN OUT [parts...]
# BIN holds the programs (test_cuda_parity_test, test_cuda_trainer_test, bench_cuda,
# train_bench: none links an I/O library; lib/ beside them is put on LD_LIBRARY_PATH; see
# docs/cuda.md); one log (and JSON) per run is packed into OUT/gpu-measure.tgz at the
# end, alone in OUT (the device tool brings back 8 files). Parts: tests bench paper tiny
# kernels scaling (default: all, in that order). Measured with it: docs/results.md.
set -uo pipefail
BIN=${1:?usage: gpu-measure.sh BIN OUT [parts...]}
OUT=${2:?usage: gpu-measure.sh BIN OUT [parts...]}
shift 2
parts=("$@")
[ ${#parts[@]} -gt 0 ] || parts=(tests bench paper tiny kernels scaling)
LOGS="$OUT/logs"
mkdir -p "$LOGS"
trap 'tar -C "$OUT" -czf "$OUT/gpu-measure.tgz" logs && rm -rf "$LOGS"' EXIT
export LD_LIBRARY_PATH="$BIN/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader | tee "$LOGS/machine.txt"
echo "cpu cores: $(nproc)" | tee -a "$LOGS/machine.txt"

run() {  # run NAME SECONDS CMD...: logs to LOGS/NAME.log
  local name=$1 limit=$2
  shift 2
  echo "== $name: $*"
  timeout "$limit" "$@" >"$LOGS/$name.log" 2>&1
  echo "   rc=$?"
}

for part in "${parts[@]}"; do
  case $part in
  tests)
    run parity 200 "$BIN/test_cuda_parity_test"
    grep -E "PASSED|FAILED" "$LOGS/parity.log" | tail -3
    run trainer 300 "$BIN/test_cuda_trainer_test"
    grep -E "PASSED|FAILED|PSNR" "$LOGS/trainer.log" | tail -4
    ;;
  bench)
    run bench 200 "$BIN/bench_cuda" --benchmark_min_time=0.3
    grep -E "^BM_" "$LOGS/bench.log" | awk '{print $1, $2, $3, $NF, $(NF-1)}'
    ;;
  paper)  # the paper preset on the 544 px synthetic subject, end to end on the GPU
    run paper_cuda 420 "$BIN/train_bench" --subject 1 --size 544 --preset paper --device cuda \
      --json "$LOGS/paper_cuda.json"
    tail -25 "$LOGS/paper_cuda.log"
    ;;
  tiny)  # the tiny preset end to end on both devices (the same subject, evaluated alike)
    for d in cuda cpu; do
      run "tiny_$d" 200 "$BIN/train_bench" --subject 1 --size 128 --preset tiny --device "$d" --json "$LOGS/tiny_$d.json"
      tail -12 "$LOGS/tiny_$d.log"
    done
    ;;
  kernels)  # GPU time per kernel over a short paper-preset run (Nsight Compute)
    run kernels 300 ncu --metrics gpu__time_duration.sum --print-summary per-kernel \
      "$BIN/train_bench" --subject 1 --size 544 --preset paper --device cuda --no-eval \
      --set s1.steps=12 --set s2.steps=6 --set s3.steps=6
    python3 "$(dirname "$0")/ncu-kernel-table.py" <"$LOGS/kernels.log" >"$LOGS/kernels_table.txt"
    head -25 "$LOGS/kernels_table.txt"
    ;;
  scaling)  # CPU ms per step of each stage at 1..16 threads (short schedules: rates, not runs;
            # the paper preset on 8 frames, so that generating the subject stays short)
    for t in 1 2 4 8 16; do
      run "tiny_cpu_t$t" 200 "$BIN/train_bench" --subject 1 --size 128 --preset tiny --device cpu --threads "$t" --no-eval \
        --set s1.steps=300 --set s2.steps=150 --set s3.steps=150 --json "$LOGS/tiny_cpu_t$t.json"
      tail -6 "$LOGS/tiny_cpu_t$t.log"
      run "paper_cpu_t$t" 240 "$BIN/train_bench" --subject 1 --size 544 --frames 8 --test-frames 1 --preset paper --device cpu --threads "$t" \
        --no-eval --set s1.steps=10 --set s2.steps=10 --set s3.steps=10 --json "$LOGS/paper_cpu_t$t.json"
      tail -6 "$LOGS/paper_cpu_t$t.log"
    done
    ;;
  *) echo "unknown part $part" >&2; exit 2 ;;
  esac
done
