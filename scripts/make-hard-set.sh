#!/usr/bin/env bash
# The harder benchmark sample set (for benchmarks, not run in CI): the default
# subject and subject 2 (another body shape, long loose hair, a loose long coat, mild
# view-dependent sheen), rendered by `haha synth` at 544 px with realistic fit noise on the
# stored SMPL-X fits (0.05 rad on every pose value, 2 cm on the translation; the true
# parameters stay in params_true.npz).
#
#   scripts/make-hard-set.sh OUT [--size 544] [--frames 40] [--test-frames 10] [--seed 0]
#                                [--haha build/cli/haha]
#
# Writes OUT/subject1/ and OUT/subject2/ (native datasets, each with contact_sheet.png and
# body_model.npz). Progress from haha synth; one line `haha: error: ...` and exit 1 on a
# bad option, a missing haha or a failed render (a finished subject folder is kept).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="" size=544 frames=40 test_frames=10 seed=0 haha="$repo/build/cli/haha"
die() { echo "haha: error: $1" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    --size|--frames|--test-frames|--seed|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in
        --size) size="$2" ;;
        --frames) frames="$2" ;;
        --test-frames) test_frames="$2" ;;
        --seed) seed="$2" ;;
        --haha) haha="$2" ;;
      esac
      shift 2 ;;
    -*) die "$1: unknown option" ;;
    *) [ -z "$out" ] || die "$1: only one OUT folder"; out="$1"; shift ;;
  esac
done
[ -n "$out" ] || die "OUT: missing (usage: scripts/make-hard-set.sh OUT [--size 544] ...)"
for kv in "--size=$size" "--frames=$frames" "--test-frames=$test_frames" "--seed=$seed"; do
  [[ "${kv#*=}" =~ ^[0-9]+$ ]] || die "${kv%%=*}: '${kv#*=}' is not a non-negative integer"
done
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"

created=0
[ -d "$out" ] || created=1
mkdir -p "$out" || die "$out: cannot create the folder"
# A failure before anything is in OUT leaves no empty folder behind.
trap '[ "$created" = 1 ] && rmdir "$out" 2>/dev/null; true' EXIT
start=$SECONDS
for subject in 1 2; do
  echo "subject $subject -> $out/subject$subject"
  # haha synth prints its own progress and its own one-line error (and leaves the target
  # folder untouched on failure).
  "$haha" synth --subject "$subject" --out "$out/subject$subject" --size "$size" --frames "$frames" \
    --test-frames "$test_frames" --seed "$seed" --fit-noise-pose 0.05 --fit-noise-transl 0.02 ||
    exit 1
done
echo "$out: subject1 and subject2, ${size}x${size}, $frames train + $test_frames test frames each, $((SECONDS - start)) s"
