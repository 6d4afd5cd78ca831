#!/usr/bin/env bash
# A real video end to end, for development measurements (never commit the video or its frames):
# fit-video with every Nth kept frame held out, training with no keys (the dataset's estimated
# fits pick their settings), evaluation on the held-out frames, the stage table printed.
#
#   scripts/measure-real-video.sh VIDEO OUT [--fps 6] [--test-every 5] [--preset tiny|paper]
#        [--fit "fit-video options"] [--train "key=value ..."] [--haha build/cli/haha]
#
# OUT/fit (the dataset, fit_report.txt), OUT/run (the avatar), OUT/eval/report.md (the stage
# table with the outline PSNR). A finished fit is reused, so training variants of one fit are
# cheap: remove OUT/fit to fit again. The held-out frames' pixels are the fitted dataset's own
# (the video's frames with the tool's masks, or the matte when fit-video matted them), so
# compare variants of training on one fit, not fits with different mattes or crops.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
video="" out="" fps=6 test_every=5 preset=tiny fit_opts="" train_keys="" haha="$repo/build/cli/haha"
die() { echo "haha: error: $1" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    --fps|--test-every|--preset|--fit|--train|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in
        --fps) fps="$2" ;; --test-every) test_every="$2" ;; --preset) preset="$2" ;;
        --fit) fit_opts="$2" ;; --train) train_keys="$2" ;; --haha) haha="$2" ;;
      esac
      shift 2 ;;
    -*) die "$1: unknown option" ;;
    *) if [ -z "$video" ]; then video="$1"; elif [ -z "$out" ]; then out="$1"; else die "$1: one VIDEO and one OUT only"; fi
       shift ;;
  esac
done
[ -n "$video" ] && [ -n "$out" ] || die "VIDEO OUT: missing (usage: scripts/measure-real-video.sh VIDEO OUT [--fps 6] ...)"
[ -f "$video" ] || die "$video: not found"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"
case "$test_every" in [2-9]|[1-9][0-9]) ;; *) die "--test-every: '$test_every' is not in 2..99" ;; esac
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
t0=$SECONDS
stamp() { echo "measure-real-video: [$1] $2 ($((SECONDS - t0)) s)"; }

mkdir -p "$out"
if [ -f "$out/fit/dataset.json" ]; then
  stamp 1/3 "fit-video: reusing $out/fit"
else
  stamp 1/3 "haha fit-video --fps $fps --test-every $test_every $fit_opts"
  # shellcheck disable=SC2086  # the options are word lists on purpose
  "$haha" fit-video "$video" --out "$out/fit" --fps "$fps" --test-every "$test_every" $fit_opts
fi
grep -E "^(crop|background plate)" "$out/fit/fit_report.txt" || true
rm -rf "$out/run" "$out/eval"
stamp 2/3 "haha train --preset $preset $train_keys"
# shellcheck disable=SC2086
"$haha" train --data "$out/fit" --out "$out/run" --preset "$preset" $train_keys
stamp 3/3 "haha eval (the run's settings)"
"$haha" eval --run "$out/run" --out "$out/eval" > "$out/eval.log"
grep -A6 "^| variant" "$out/eval/report.md"
stamp done "$out/eval/report.md"
