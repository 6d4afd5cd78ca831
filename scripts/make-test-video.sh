#!/usr/bin/env bash
# The synthetic test video of `haha fit-video` (issue 18's end-to-end measurement): the
# embedded subject rendered by `haha synth` at 512 px with known SMPL-X fits, its frames
# H.264-encoded with ffmpeg so the keypoint tool sees what a user gives it.
#
#   scripts/make-test-video.sh OUT [--size 512] [--frames 40] [--test-frames 10] [--seed 0]
#                                  [--fps 30] [--haha build/cli/haha]
#
# Writes OUT/synth/ (the dataset with the exact fits and body_model.npz: the reference to
# compare the fit with and to train the exact-fit avatar on), OUT/video.mp4 (the training
# frames: one slow turn), OUT/video_test.mp4 (the test frames: novel poses) and
# OUT/video_all.mp4 (both, in that order: `haha fit-video --test-from FRAMES` holds the
# test frames out with one shared fit, as the avatar comparison needs). Progress
# from haha synth; one line `haha: error: ...` and exit 1 when ffmpeg or haha is missing.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="" size=512 frames=40 test_frames=10 seed=0 fps=30 haha="$repo/build/cli/haha"
die() { echo "haha: error: $1" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    --size|--frames|--test-frames|--seed|--fps|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in
        --size) size="$2" ;;
        --frames) frames="$2" ;;
        --test-frames) test_frames="$2" ;;
        --seed) seed="$2" ;;
        --fps) fps="$2" ;;
        --haha) haha="$2" ;;
      esac
      shift 2 ;;
    -*) die "$1: unknown option" ;;
    *) [ -z "$out" ] || die "$1: only one OUT folder"; out="$1"; shift ;;
  esac
done
[ -n "$out" ] || die "OUT: missing (usage: scripts/make-test-video.sh OUT [--size 512] ...)"
command -v ffmpeg >/dev/null 2>&1 || die "ffmpeg: not installed (apt-get install ffmpeg)"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"

mkdir -p "$out"
"$haha" synth --out "$out/synth" --size "$size" --frames "$frames" --test-frames "$test_frames" --seed "$seed"
encode() {  # FIRST COUNT FILE
  ffmpeg -nostdin -y -v error -framerate "$fps" -start_number "$1" -i "$out/synth/images/%06d.png" \
    -frames:v "$2" -c:v libx264 -pix_fmt yuv420p -crf 18 "$3.tmp.mp4"
  mv "$3.tmp.mp4" "$3"
  echo "$3: $2 frames, ${size}x${size}, $fps fps"
}
encode 0 "$frames" "$out/video.mp4"
if [ "$test_frames" -gt 0 ]; then
  encode "$frames" "$test_frames" "$out/video_test.mp4"
  encode 0 "$((frames + test_frames))" "$out/video_all.mp4"
fi
