#!/usr/bin/env bash
# The avatar measurement of fit-video: is an avatar trained from `haha fit-video`'s fits as good as
# one trained from the exact fits, on the same held-out frames?
#
#   scripts/measure-fit-video.sh OUT [--held-out novel|every:N] [--backdrop black|room|bright]
#        [--still-arms] [--frames N] [--haha build/cli/haha] [--fit "fit-video options"] [--preset tiny|paper]
#        [--train "key=value ..."] [--eval "--antialias --tto-steps 100"]
#
# 1. scripts/make-test-video.sh OUT (the embedded subject at 512 px: 40 frames of a turn and
#    10 test frames in novel poses, with the exact fits in OUT/synth; --backdrop: behind the
#    subject in the video, black by default; --still-arms: arms held still over the turn;
#    see make-test-video.sh; --frames: the turn in N frames instead of 40, a slower turn);
# 2. haha fit-video (one fit, --truth OUT/synth for the joint error; --fit adds options, e.g.
#    "--focal 643.4" for a calibrated camera) on the subject's own body model, so that only
#    the fits differ. Held-out frames:
#      novel (default): OUT/video_all.mp4 --test-from 40: the 10 novel poses. They follow
#        each other like a slide show, which the fit's temporal smoothness does not expect;
#      every:N: OUT/video.mp4 --test-every N: every Nth frame of the turn, as a video's
#        held-out frames usually are.
#    The exact dataset gets the fitted one's split (OUT/synth_split);
# 3. trains the tiny preset (--preset) on both datasets with the same settings (--train;
#    default the recommendation (docs/fit-video.md) for imperfect fits) and evaluates both on the test
#    split with the same options (--eval). The fitted avatar is evaluated with its fitted
#    test poses (and test-time pose optimisation) against the same ground-truth pixels as
#    the exact one:
#    OUT/fit_eval is OUT/fit with the test frames' images and masks replaced by the synth
#    PNGs (the video frames are H.264-decoded and the tool's masks are not exact), cut to
#    the fitted dataset's source_crop (with ffmpeg's crop filter) when fit-video cropped it.
#    Cropped, the fitted avatar trains and is scored on the person's box, the exact one on
#    the whole frames (more easy background): for like-for-like PSNRs give --fit --no-crop;
# 4. prints both eval tables and the two HAHA rows. Needs python3 (the JSON edit of step 3).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="" haha="$repo/build/cli/haha" motion=() frames=40
held_out="novel" backdrop="black" preset="tiny" fit_opts="" train_keys="s0.photo.steps=6000 s1.lr.pose=0.005" eval_opts="--antialias --tto-steps 100"
die() { echo "haha: error: $1" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,31p' "$0"; exit 0 ;;
    --still-arms) motion=(--still-arms); shift ;;
    --held-out|--backdrop|--preset|--haha|--fit|--train|--eval|--frames)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in
        --held-out) held_out="$2" ;; --backdrop) backdrop="$2" ;; --preset) preset="$2" ;;
        --haha) haha="$2" ;; --fit) fit_opts="$2" ;; --train) train_keys="$2" ;; --eval) eval_opts="$2" ;;
        --frames) frames="$2" ;;
      esac
      shift 2 ;;
    -*) die "$1: unknown option" ;;
    *) [ -z "$out" ] || die "$1: only one OUT folder"; out="$1"; shift ;;
  esac
done
[ -n "$out" ] || die "OUT: missing (usage: scripts/measure-fit-video.sh OUT [--held-out novel|every:N] ...)"
case "$held_out" in
  novel) test_frames=10 split_opts="--test-from $frames" video="video_all.mp4" ;;
  every:[2-9]|every:[1-9][0-9])
    test_frames=0 split_opts="--test-every ${held_out#every:}" video="video.mp4" ;;
  *) die "--held-out: '$held_out' is neither novel nor every:N (N in 2..99)" ;;
esac
command -v python3 >/dev/null 2>&1 || die "python3: not installed (apt-get install python3)"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
t0=$SECONDS
stamp() { echo "measure-fit-video: [$1] $2 ($((SECONDS - t0)) s)"; }

stamp 1/5 "synthetic video"
bash "$repo/scripts/make-test-video.sh" "$out" --haha "$haha" --frames "$frames" --test-frames "$test_frames" \
  --backdrop "$backdrop" "${motion[@]}"
stamp 2/5 "haha fit-video"
# shellcheck disable=SC2086  # the options are word lists on purpose
"$haha" fit-video "$out/$video" --out "$out/fit" $split_opts --model "$out/synth/body_model.npz" \
  --truth "$out/synth" $fit_opts

stamp 3/5 "eval dataset of the fitted avatar: test frames on the synth pixels"
rm -rf "$out/fit_eval"
cp -r "$out/fit" "$out/fit_eval"
python3 - "$out/fit_eval" "$out/synth" <<'EOF'
import json, shutil, subprocess, sys
ev, synth = sys.argv[1], sys.argv[2]
d = json.load(open(ev + "/dataset.json"))
crop = d.get("source_crop")  # [x0, y0, w, h]: the fitted dataset is this box of the video's frames
for f in d["frames"]:
    if f["split"] == "test":  # decoded frame i of video_all.mp4 is synth frame i
        i = f["source_index"]
        for src, dst in ((synth + "/images/%06d.png" % i, ev + "/" + f["image"]),
                         (synth + "/masks/%06d.png" % i, ev + "/" + f["mask"])):
            if crop:  # a lossless cut: the PNG keeps its pixel format (RGB, grey)
                subprocess.run(["ffmpeg", "-nostdin", "-y", "-v", "error", "-i", src, "-vf",
                                "crop=%d:%d:%d:%d" % (crop[2], crop[3], crop[0], crop[1]), "-frames:v", "1", dst],
                               check=True)
            else:
                shutil.copyfile(src, dst)
d["premultiplied"] = True  # the synth PNGs are composited on black with their soft masks
json.dump(d, open(ev + "/dataset.json.tmp", "w"), indent=1)
EOF
mv "$out/fit_eval/dataset.json.tmp" "$out/fit_eval/dataset.json"
# The exact fits with the fitted dataset's held-out frames (decoded frame i = synth frame i).
rm -rf "$out/synth_split"
cp -r "$out/synth" "$out/synth_split"
python3 - "$out/fit/dataset.json" "$out/synth_split/dataset.json" <<'EOF'
import json, sys
fit, ex = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
test = {f["source_index"] for f in fit["frames"] if f["split"] == "test"}
for i, f in enumerate(ex["frames"]):
    f["split"] = "test" if i in test else "train"
json.dump(ex, open(sys.argv[2] + ".tmp", "w"), indent=1)
EOF
mv "$out/synth_split/dataset.json.tmp" "$out/synth_split/dataset.json"

# shellcheck disable=SC2086  # the settings are word lists on purpose
for which in exact fit; do
  data="$out/synth_split"; [ "$which" = fit ] && data="$out/fit"
  stamp 4/5 "train ($which fits): haha train --preset $preset $train_keys"
  "$haha" train --data "$data" --model "$out/synth/body_model.npz" --out "$out/run_$which" --preset "$preset" $train_keys
done
for which in exact fit; do
  data="$out/synth_split"; [ "$which" = fit ] && data="$out/fit_eval"
  stamp 5/5 "eval ($which fits): haha eval $eval_opts"
  "$haha" eval --run "$out/run_$which" --data "$data" $eval_opts > "$out/eval_$which.txt"
done
for which in exact fit; do echo "== avatar from the $which fits"; cat "$out/eval_$which.txt"; done
echo "== held out: $held_out, $eval_opts:"
for which in exact fit; do echo "$which fits: $(grep -m1 -E '^ +HAHA filtered +PSNR' "$out/eval_$which.txt")"; done
stamp done "tables above; runs in $out/run_exact, $out/run_fit"
