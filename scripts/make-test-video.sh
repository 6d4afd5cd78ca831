#!/usr/bin/env bash
# The synthetic test video of `haha fit-video` (its end-to-end measurement): the
# embedded subject rendered by `haha synth` at 512 px with known SMPL-X fits, its frames
# H.264-encoded with ffmpeg so the keypoint tool sees what a user gives it.
#
#   scripts/make-test-video.sh OUT [--size 512] [--frames 40] [--test-frames 10] [--seed 0]
#                                  [--fps 30] [--backdrop black|room|bright] [--still-arms]
#                                  [--haha build/cli/haha]
#
# --backdrop: what stands behind the subject in the videos. black (default): haha synth's
# frames as they are (premultiplied on black; black leggings on black are a worst case for
# any person mask); room: a static procedural room (a shaded wall, a tiled floor behind the
# feet; OUT/backdrop.png) composited behind the subject with the true soft masks, as a
# tripod video of a person would show it; bright: the same with a near-white wall and a
# light floor, as a home video against a white wall (where a soft mask's leaked backdrop
# shows most). OUT/synth/ stays on black either way.
# --still-arms: the subject holds its arms in one A-pose while it turns (`haha synth
# --still-arms`, as PeopleSnapshot-style captures do) instead of swinging them.
#
# Writes OUT/synth/ (the dataset with the exact fits and body_model.npz: the reference to
# compare the fit with and to train the exact-fit avatar on), OUT/video.mp4 (the training
# frames: one slow turn), OUT/video_test.mp4 (the test frames: novel poses) and
# OUT/video_all.mp4 (both, in that order: `haha fit-video --test-from FRAMES` holds the
# test frames out with one shared fit, as the avatar comparison needs). Progress
# from haha synth; one line `haha: error: ...` and exit 1 when ffmpeg or haha is missing.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="" size=512 frames=40 test_frames=10 seed=0 fps=30 backdrop=black haha="$repo/build/cli/haha" motion=()
die() { echo "haha: error: $1" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,25p' "$0"; exit 0 ;;
    --still-arms) motion=(--still-arms); shift ;;
    --size|--frames|--test-frames|--seed|--fps|--backdrop|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in
        --size) size="$2" ;;
        --frames) frames="$2" ;;
        --test-frames) test_frames="$2" ;;
        --seed) seed="$2" ;;
        --fps) fps="$2" ;;
        --backdrop) backdrop="$2" ;;
        --haha) haha="$2" ;;
      esac
      shift 2 ;;
    -*) die "$1: unknown option" ;;
    *) [ -z "$out" ] || die "$1: only one OUT folder"; out="$1"; shift ;;
  esac
done
[ -n "$out" ] || die "OUT: missing (usage: scripts/make-test-video.sh OUT [--size 512] ...)"
case "$backdrop" in black|room|bright) ;; *) die "--backdrop: '$backdrop' is not black, room or bright" ;; esac
command -v ffmpeg >/dev/null 2>&1 || die "ffmpeg: not installed (apt-get install ffmpeg)"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"

mkdir -p "$out"
"$haha" synth --out "$out/synth" --size "$size" --frames "$frames" --test-frames "$test_frames" --seed "$seed" \
  "${motion[@]}"
if [ "$backdrop" = room ]; then
  # A wall with soft folds and fine stripes above a two-tone tiled floor (RGB 0..255 per pixel).
  wall="sin(X/41)*sin(Y/67)" stripes="10*sin(X/7.3)"
  tile="mod(floor(X/(W/6))+floor((Y-H*0.8)/(H/24)),2)" floor="gt(Y,H*0.8)"
  ffmpeg -nostdin -y -v error -f lavfi -i "color=c=gray:s=${size}x${size}:d=1,format=gbrp,geq=\
r='if($floor,105+35*$tile,172+22*$wall+$stripes)':\
g='if($floor,92+32*$tile,160+20*$wall+$stripes)':\
b='if($floor,80+28*$tile,138+16*$wall+$stripes)'" -frames:v 1 "$out/backdrop.tmp.png"
  mv "$out/backdrop.tmp.png" "$out/backdrop.png"
elif [ "$backdrop" = bright ]; then
  # A near-white wall (faint shading, a little darker towards the floor) above a light floor
  # of large pale tiles.
  shade="sin(X/53)*sin(Y/71)" fall="Y/H" tile="mod(floor(X/(W/4))+floor((Y-H*0.8)/(H/16)),2)" floor="gt(Y,H*0.8)"
  ffmpeg -nostdin -y -v error -f lavfi -i "color=c=white:s=${size}x${size}:d=1,format=gbrp,geq=\
r='if($floor,214+8*$tile,246+5*$shade-12*$fall)':\
g='if($floor,206+8*$tile,244+5*$shade-12*$fall)':\
b='if($floor,194+8*$tile,238+5*$shade-12*$fall)'" -frames:v 1 "$out/backdrop.tmp.png"
  mv "$out/backdrop.tmp.png" "$out/backdrop.png"
fi
encode() {  # FIRST COUNT FILE
  local frames_in=(-framerate "$fps" -start_number "$1" -i "$out/synth/images/%06d.png")
  if [ "$backdrop" != black ]; then
    # The frames are premultiplied on black: back to straight colour with their soft masks as
    # alpha, then over the backdrop: rgb + backdrop x (1 - mask).
    ffmpeg -nostdin -y -v error "${frames_in[@]}" -framerate "$fps" -start_number "$1" \
      -i "$out/synth/masks/%06d.png" -loop 1 -framerate "$fps" -i "$out/backdrop.png" -filter_complex \
      "[0:v]format=gbrap[c];[1:v]format=gray[m];[c][m]alphamerge,unpremultiply=inplace=1[fg];\
[2:v]format=gbrp[bg];[bg][fg]overlay=shortest=1:format=gbrp,format=yuv420p[v]" -map "[v]" \
      -frames:v "$2" -c:v libx264 -crf 18 "$3.tmp.mp4"
  else
    ffmpeg -nostdin -y -v error "${frames_in[@]}" -frames:v "$2" -c:v libx264 -pix_fmt yuv420p -crf 18 "$3.tmp.mp4"
  fi
  mv "$3.tmp.mp4" "$3"
  echo "$3: $2 frames, ${size}x${size}, $fps fps, backdrop $backdrop"
}
encode 0 "$frames" "$out/video.mp4"
if [ "$test_frames" -gt 0 ]; then
  encode "$frames" "$test_frames" "$out/video_test.mp4"
  encode 0 "$((frames + test_frames))" "$out/video_all.mp4"
fi
