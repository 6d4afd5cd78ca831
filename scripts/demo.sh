#!/usr/bin/env bash
# The whole pipeline on the embedded sample (the README's first command):
#   install + build -> haha synth -> haha train --preset tiny -> haha eval -> haha pack
#   -> haha motion (a pose sequence the avatar never saw) -> haha render -> MP4 + GIF.
# Usage: bash scripts/demo.sh [--out DIR] [--no-build] [--haha PATH]
# (train / eval / render run on the CPU; the GPU path is `haha bench --device cuda`.)
# Outputs go to out/demo (gitignored) unless --out says otherwise. Sized for 2 CPU cores
# and about ten minutes in all.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

out=out/demo
build=1
haha="$root/build/cli/haha"
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out="$2"; shift 2 ;;
    --no-build) build=0; shift ;;
    --haha) haha=$(realpath "$2"); build=0; shift 2 ;;  # an already built haha (development)
    -h|--help) sed -n '2,8p' "$0"; exit 0 ;;
    *) echo "demo.sh: unknown argument '$1' (--out DIR, --no-build, --haha PATH)" >&2; exit 2 ;;
  esac
done

# Idle OpenMP threads sleep instead of spinning: on a machine whose cores are shared
# (CI, a laptop doing other work) spinning threads wait for the scheduler at every parallel
# loop; measured here, tiny training ran 2x faster (26 vs 12 steps/s) with passive waits.
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}

t0=$(date +%s)
declare -a times=()
step_start=$t0
step() {  # step NAME: prints a banner with the elapsed time
  local now; now=$(date +%s)
  if [ -n "${step_name:-}" ]; then times+=("$(printf '%-8s %4d s' "$step_name" $((now - step_start)))"); fi
  step_name="$1"; step_start=$now
  printf '\n==> [%3d s] %s\n' $((now - t0)) "$2"
}

step build "install dependencies and build the haha command (scripts/build.sh --target haha)"
if [ "$build" = 1 ]; then
  # Only what the demo runs: the `haha` command, without the tests (their libraries, npm
  # packages, browser and keypoint tool: scripts/test.sh installs and builds those), and
  # without the CUDA objects where no GPU answers nvidia-smi (test.sh builds them).
  cuda=OFF
  if nvidia-smi -L 2>/dev/null | grep -q '^GPU'; then cuda=ON; fi
  HAHA_BUILD_ONLY=1 bash scripts/build.sh --target haha -DHAHA_WITH_CUDA=$cuda -DHAHA_BUILD_TESTS=OFF
fi
[ -x "$haha" ] || { echo "demo.sh: $haha is not built (run without --no-build)" >&2; exit 1; }

# A fresh output folder; a previous demo's folder (marked) is replaced, anything else is kept.
if [ -e "$out" ] && [ -n "$(ls -A "$out" 2>/dev/null)" ]; then
  if [ -f "$out/.haha-demo" ]; then
    rm -rf "$out/data" "$out/run" "$out/render" "$out/avatar.glb" "$out/motion_wave.npz" "$out/animation.mp4" \
           "$out/animation.gif" "$out/animation_strip.png"
  else
    echo "demo.sh: $out exists and is not a previous demo's output; choose another --out" >&2; exit 1
  fi
fi
mkdir -p "$out"
touch "$out/.haha-demo"

step synth "synthesize the sample subject: 40 training frames (one turn) + 10 novel test poses, 128 px"
"$haha" synth --out "$out/data"

step train "train the avatar: the three HAHA stages, preset tiny (Gaussians, texture, filtering)"
"$haha" train --data "$out/data" --out "$out/run" --preset tiny

step eval "evaluate on the novel test poses: mesh only / full Gaussians / naive merge / HAHA"
"$haha" eval --run "$out/run"

step pack "pack the avatar into one .glb (skinned textured mesh + Gaussians, Draco)"
"$haha" pack "$out/run" --out "$out/avatar.glb"
"$haha" info "$out/avatar.glb"

step render "repose with a new motion (waving, never seen in training) and render an animation"
"$haha" motion --kind wave --frames 48 --fps 24 --out "$out/motion_wave.npz"
"$haha" render "$out/avatar.glb" --motion "$out/motion_wave.npz" --model "$out/data/body_model.npz" \
  --out "$out/render" --size 256 --video "$out/animation.mp4"
# A GIF too: it plays inline in browsers, chat and Markdown viewers.
ffmpeg -y -loglevel error -framerate 24 -i "$out/render/frame_%05d.png" \
  -vf "split[a][b];[a]palettegen=max_colors=128[p];[b][p]paletteuse" "$out/animation.gif"
# And a strip of every eighth frame, cropped to the person (README's picture is one).
ffmpeg -y -loglevel error -i "$out/render/frame_%05d.png" \
  -vf "select='not(mod(n\,8))',crop=iw*0.45:ih*0.92:iw*0.27:0,tile=6x1" -frames:v 1 "$out/animation_strip.png"

step done "finished"
printf '\nstage times:\n'
for t in "${times[@]}"; do printf '  %s\n' "$t"; done
printf '  total    %4d s\n' $(( $(date +%s) - t0 ))
cat <<EOF

Results (in $out):
  avatar         $out/avatar.glb               (open in any glTF viewer; haha info / unpack / render)
  report         $out/run/report.md            (PSNR / SSIM / Gaussians / storage / training time per variant)
  contact sheet  $out/run/eval_sheet.png       (ground truth | HAHA | error | Gaussian layer | mesh only | full Gaussians)
  training data  $out/data/contact_sheet.png   (the synthetic video and its novel test poses)
  animation      $out/animation.mp4, $out/animation.gif, $out/animation_strip.png   (new motion, $(ls "$out/render" | wc -l) frames)
Next: speed and size against error (about 2 minutes on 2 cores) with
  OMP_WAIT_POLICY=passive $haha bench --run $out/run --out $out/bench
EOF
