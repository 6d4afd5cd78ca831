#!/usr/bin/env bash
# PeopleSnapshot, the protocol of the literature: convert, train and evaluate the four subjects
# the papers report (InstantAvatar's preprocessing and split) and write a table laid out like
# the HAHA paper's (table "tab:snapshot") with the published rows beside ours.
#
#   scripts/peoplesnapshot.sh PS_ROOT OUT --model SMPLX_NEUTRAL.npz --smpl-model SMPL_NEUTRAL.npz
#        [--smpl-correspondence F] [--lpips-weights F] [--preset paper|tiny] [--device auto|cpu|cuda]
#        [--subjects "male-3-casual ..."] [--train "key=value ..."] [--eval "haha eval options"]
#        [--frames "SUBJECT=TRAIN,TEST ..."] [--size PX] [--haha build/cli/haha]
#
# PS_ROOT holds one folder per subject in InstantAvatar's layout (images/, masks/, poses/,
# cameras.npz; docs/data.md). For each subject S (default: male-3-casual male-4-casual
# female-3-casual female-4-casual), under OUT/S/:
#   1. haha convert --from peoplesnapshot --in PS_ROOT/S --out OUT/S/data --size 540
#      --train-frames TRAIN --test-frames TEST --model ... --smpl-model ... [--smpl-correspondence]
#      with the field's split (START:END:STEP, END exclusive; the frames of InstantAvatar's
#      inclusive ranges): male-3-casual 0:456:4 / 456:676:4, male-4-casual 0:660:6 / 660:873:6,
#      female-3-casual 0:446:4 / 446:648:4, female-4-casual 0:336:4 / 335:524:4;
#   2. haha train --data OUT/S/data --out OUT/S/run --model ... --preset P --device D
#      resolution=540 [--train keys] (--lpips-weights too with --device cpu: the LPIPS loss has
#      no GPU path yet); a run with a checkpoint is resumed (--resume);
#   3. haha eval --run OUT/S/run --out OUT/S/eval --split test --background black
#      [--lpips-weights F] [--eval options]: test-time pose optimisation with the run's
#      eval.tto_steps; OUT/S/eval.json is a copy of its report.json, written last;
#   4. OUT/table.md from every OUT/S/eval.json (python3): per sequence Gaussians / PSNR / SSIM /
#      LPIPS of HAHA filtered and full Gaussians under the published rows, and the means over
#      the sequences run.
# Resume-friendly: a subject whose OUT/S/eval.json exists is skipped (delete OUT/S to redo it),
# a converted dataset (OUT/S/data/dataset.json) or a finished run (train_summary.json) is kept.
# --frames overrides the split of a subject ("S=TRAIN,TEST", space-separated; needed for a
# subject not in the list above); --size another frame size (the protocol is 540; training uses
# resolution=PX so frames are not resampled). Every argument is checked, and every subject
# folder looked for, before anything runs.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
die() { echo "haha: error: $1" >&2; exit 1; }
ps_root="" out="" model="" smpl_model="" corr="" lpips="" preset="paper" device="auto"
subjects="male-3-casual male-4-casual female-3-casual female-4-casual"
train_keys="" eval_opts="" frames_opt="" size=540 haha="$repo/build/cli/haha"
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,33p' "$0"; exit 0 ;;
    --model|--smpl-model|--smpl-correspondence|--lpips-weights|--preset|--device|--subjects|--train|--eval|--frames|--size|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in
        --model) model="$2" ;; --smpl-model) smpl_model="$2" ;; --smpl-correspondence) corr="$2" ;;
        --lpips-weights) lpips="$2" ;; --preset) preset="$2" ;; --device) device="$2" ;;
        --subjects) subjects="$2" ;; --train) train_keys="$2" ;; --eval) eval_opts="$2" ;;
        --frames) frames_opt="$2" ;; --size) size="$2" ;; --haha) haha="$2" ;;
      esac
      shift 2 ;;
    -*) die "$1: unknown option (see scripts/peoplesnapshot.sh --help)" ;;
    *)
      if [ -z "$ps_root" ]; then ps_root="$1"
      elif [ -z "$out" ]; then out="$1"
      else die "$1: only PS_ROOT and OUT are positional"; fi
      shift ;;
  esac
done
usage="usage: scripts/peoplesnapshot.sh PS_ROOT OUT --model SMPLX_NEUTRAL.npz --smpl-model SMPL_NEUTRAL.npz ..."
[ -n "$ps_root" ] || die "PS_ROOT: missing ($usage)"
[ -n "$out" ] || die "OUT: missing ($usage)"
[ -d "$ps_root" ] || die "$ps_root: no such folder (PS_ROOT: PeopleSnapshot in InstantAvatar's layout)"
[ -n "$model" ] || die "--model: missing (the SMPL-X model file, e.g. SMPLX_NEUTRAL.npz)"
[ -n "$smpl_model" ] || die "--smpl-model: missing (the SMPL model file the poses were fitted with, e.g. SMPL_NEUTRAL.npz)"
for f in "$model" "$smpl_model" ${corr:+"$corr"} ${lpips:+"$lpips"}; do
  [ -f "$f" ] || die "$f: no such file"
done
case "$preset" in paper|tiny) ;; *) die "--preset: '$preset' is neither paper nor tiny" ;; esac
case "$device" in auto|cpu|cuda) ;; *) die "--device: '$device' is not auto, cpu or cuda" ;; esac
{ [[ "$size" =~ ^[1-9][0-9]{1,4}$ ]] && [ "$size" -ge 16 ]; } || die "--size: '$size' is not a frame size in pixels (>= 16)"
command -v python3 >/dev/null 2>&1 || die "python3: not installed (apt-get install python3)"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"

# The field's split (InstantAvatar / 3DGS-Avatar configs, inclusive ends turned exclusive).
declare -A split=(
  [male-3-casual]="0:456:4,456:676:4"
  [male-4-casual]="0:660:6,660:873:6"
  [female-3-casual]="0:446:4,446:648:4"
  [female-4-casual]="0:336:4,335:524:4"
)
range_re='[0-9]+:[0-9]+(:[0-9]+)?'
for entry in $frames_opt; do
  [[ "$entry" =~ ^([A-Za-z0-9._-]+)=($range_re),($range_re)$ ]] ||
    die "--frames: '$entry' is not SUBJECT=START:END[:STEP],START:END[:STEP]"
  split[${entry%%=*}]="${entry#*=}"
done
[ -n "${subjects// /}" ] || die "--subjects: empty"
for s in $subjects; do
  [[ "$s" =~ ^[A-Za-z0-9][A-Za-z0-9._-]*$ ]] || die "--subjects: '$s' is not a subject folder name"
  [ -n "${split[$s]:-}" ] || die "--subjects: $s: no split known (give it with --frames \"$s=TRAIN,TEST\")"
  [ -d "$ps_root/$s" ] || die "$ps_root/$s: no such subject folder (PeopleSnapshot in InstantAvatar's layout: images/, masks/, poses/, cameras.npz)"
done

export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$out"
t0=$SECONDS
stamp() { echo "peoplesnapshot: [$1] $2 ($((SECONDS - t0)) s)"; }
train_lpips=()
[ -n "$lpips" ] && [ "$device" = cpu ] && train_lpips=(--lpips-weights "$lpips")
eval_lpips=()
[ -n "$lpips" ] && eval_lpips=(--lpips-weights "$lpips")

for s in $subjects; do
  d="$out/$s"
  if [ -f "$d/eval.json" ]; then
    stamp "$s" "$d/eval.json exists: skipped (delete $d to redo it)"
    continue
  fi
  mkdir -p "$d"
  tr="${split[$s]%%,*}" te="${split[$s]#*,}"
  if [ -f "$d/data/dataset.json" ]; then
    stamp "$s" "converted dataset $d/data exists: kept"
  else
    stamp "$s" "haha convert --from peoplesnapshot --size $size --train-frames $tr --test-frames $te"
    "$haha" convert --from peoplesnapshot --in "$ps_root/$s" --out "$d/data" --size "$size" \
      --train-frames "$tr" --test-frames "$te" --model "$model" --smpl-model "$smpl_model" \
      ${corr:+--smpl-correspondence "$corr"}
  fi
  if [ -f "$d/run/train_summary.json" ]; then
    stamp "$s" "trained run $d/run exists: kept"
  elif [ -f "$d/run/checkpoint.npz" ]; then
    stamp "$s" "haha train --resume (device $device)"
    "$haha" train --resume --out "$d/run" --device "$device"
  else
    stamp "$s" "haha train --preset $preset --device $device resolution=$size $train_keys"
    # shellcheck disable=SC2086  # the keys are a word list on purpose
    "$haha" train --data "$d/data" --model "$model" --out "$d/run" --preset "$preset" --device "$device" \
      "${train_lpips[@]}" "resolution=$size" $train_keys
  fi
  stamp "$s" "haha eval --split test --background black $eval_opts"
  # shellcheck disable=SC2086  # the options are a word list on purpose
  "$haha" eval --run "$d/run" --out "$d/eval" --split test --background black "${eval_lpips[@]}" $eval_opts
  cp "$d/eval/report.json" "$d/eval.json.tmp"
  mv "$d/eval.json.tmp" "$d/eval.json"
done

stamp table "$out/table.md"
python3 - "$out" "$subjects" > "$out/table.md.tmp" <<'EOF'
import json, math, os, sys
from decimal import Decimal, ROUND_HALF_UP

out, asked = sys.argv[1], sys.argv[2].split()
PAPER = ["female-3-casual", "male-3-casual", "male-4-casual", "female-4-casual"]
# As published in the HAHA paper (Svitov et al., ACCV 2024), table "tab:snapshot":
# Gaussians (thousands), PSNR, SSIM, LPIPS per sequence.
REF = [  # strings, read as exact decimals
    ("3DGS-Avatar", {"female-3-casual": ("53.78", "30.57", "0.9581", "0.0208"), "male-3-casual": ("37.22", "34.28", "0.9724", "0.0149"),
                     "male-4-casual": ("35.96", "30.22", "0.9653", "0.0230"), "female-4-casual": ("33.44", "33.16", "0.9678", "0.0157")}),
    ("GART", {"female-3-casual": ("19.67", "32.73", "0.9672", "0.0459"), "male-3-casual": ("21.88", "35.93", "0.9767", "0.0294"),
              "male-4-casual": ("20.37", "33.17", "0.9719", "0.0376"), "female-4-casual": ("21.22", "34.42", "0.9706", "0.0328")}),
    ("GaussianAvatar", {"female-3-casual": ("202.73", "25.94", "0.9673", "0.0434"), "male-3-casual": ("202.73", "33.59", "0.9697", "0.0243"),
                        "male-4-casual": ("202.73", "30.83", "0.9676", "0.0302"), "female-4-casual": ("202.73", "32.98", "0.9676", "0.0239")}),
    ("HAHA (authors)", {"female-3-casual": ("13.67", "32.53", "0.9633", "0.0403"), "male-3-casual": ("13.60", "31.46", "0.9619", "0.0277"),
                        "male-4-casual": ("14.64", "27.08", "0.9505", "0.0432"), "female-4-casual": ("11.96", "31.15", "0.9589", "0.0283")}),
]
OURS = [("HAHA filtered", "HAHA filtered"), ("full Gaussians", "full Gaussians")]


def dec(v):  # published numbers exactly, ours as the json holds them; None for n/a
    if v is None or isinstance(v, Decimal):
        return v
    return Decimal(repr(float(v))) if math.isfinite(v) else None


def fnum(v, places, suffix=""):  # rounded half up, as a table is read
    v = dec(v)
    return "n/a" if v is None else str(v.quantize(Decimal(1).scaleb(-places), rounding=ROUND_HALF_UP)) + suffix


def cells(g_k, psnr, ssim, lpips):
    return [fnum(g_k, 2, "k"), fnum(psnr, 2), fnum(ssim, 4), fnum(lpips, 4)]


runs = {}  # sequence -> eval json
for s in PAPER + [s for s in asked if s not in PAPER]:
    p = os.path.join(out, s, "eval.json")
    if os.path.isfile(p):
        with open(p) as f:
            runs[s] = json.load(f)


def ours(s, variant):
    v = {x["name"]: x for x in runs[s]["variants"]}[variant]
    return (v["gaussians"] / 1000.0, v["psnr"], v["ssim"], v["lpips"])


seqs = PAPER + [s for s in runs if s not in PAPER]
print("# PeopleSnapshot: HAHA against the literature\n")
print("""Protocol: InstantAvatar's preprocessing and split of the four sequences, frames at 540 px
(each run's resolution: Runs, below), metrics on the test frames on a black background with
test-time pose optimisation, as the HAHA paper evaluates (its table "tab:snapshot").
Sources: [paper] = as published in the HAHA paper (Svitov et al., ACCV 2024), table
"tab:snapshot" (female-3 / male-3-casual in the main paper, male-4 / female-4-casual in the
supplementary), the other methods' rows as that table reports them; [run] = this run,
`OUT/SEQUENCE/eval.json` (`haha eval`'s report.json).
""")
for i in range(0, len(seqs), 2):
    pair = seqs[i:i + 2]
    print("| method [source] |" + "".join(" %s: Gaussians ↓ | PSNR ↑ | SSIM ↑ | LPIPS ↓ |" % s for s in pair))
    print("|---|" + "---:|" * (4 * len(pair)))
    for name, ref in REF:
        if any(s in ref for s in pair):
            row = []
            for s in pair:
                row += cells(*map(Decimal, ref[s])) if s in ref else ["–"] * 4
            print("| %s [paper] | %s |" % (name, " | ".join(row)))
    for label, variant in OURS:
        row = []
        for s in pair:
            row += cells(*ours(s, variant)) if s in runs else ["–"] * 4
        print("| %s [run] | %s |" % (label, " | ".join(row)))
    print()

done = [s for s in seqs if s in runs]
print("## Mean over the sequences run\n")
if not done:
    print("No sequence has an eval.json yet.")
else:
    print("Sequences: %s (%d of 4 of the paper's). The published rows are averaged over the same"
          % (", ".join(done), len([s for s in done if s in PAPER])))
    print("sequences; a method without a published number for one of them shows n/a.\n")
    print("| method [source] | Gaussians ↓ | PSNR ↑ | SSIM ↑ | LPIPS ↓ |")
    print("|---|---:|---:|---:|---:|")

    def mean(rows):
        m = []
        for k in range(4):
            vals = [dec(r[k]) for r in rows]
            m.append(sum(vals) / len(vals) if all(v is not None for v in vals) else None)
        return m

    for name, ref in REF:
        m = mean([tuple(map(Decimal, ref[s])) for s in done]) if all(s in ref for s in done) else [None] * 4
        print("| %s [paper] | %s |" % (name, " | ".join(cells(*m))))
    for label, variant in OURS:
        print("| %s [run] | %s |" % (label, " | ".join(cells(*mean([ours(s, variant) for s in done])))))
    print()
    print("Published means over all four sequences (PSNR): " + ", ".join(
        "%s %s dB" % (name, fnum(sum(Decimal(ref[s][1]) for s in PAPER) / 4, 2)) for name, ref in REF) + ".\n")
    print("## Runs\n")
    print("| sequence | preset | resolution (px) | test frames | test-time pose optimisation | background | LPIPS |")
    print("|---|---|---:|---:|---:|---|---|")
    for s in done:
        r = runs[s]
        frames = len(r["variants"][0].get("frames", [])) if r["variants"] else 0
        try:  # the run's training (and evaluation) resolution
            with open(os.path.join(out, s, "run", "config.json")) as f:
                res = str(json.load(f)["config"]["resolution"])
        except (OSError, KeyError, TypeError, ValueError):
            res = "?"
        print("| %s | %s | %s | %d | %d steps | %s | %s |" % (s, r.get("preset", "?"), res, frames, r.get("tto_steps", 0),
                                                            r.get("background", "?"), r.get("lpips", "?")))
EOF
mv "$out/table.md.tmp" "$out/table.md"
cat "$out/table.md"
stamp "done" "table in $out/table.md"
