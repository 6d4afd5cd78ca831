#!/usr/bin/env bash
# A suite of real clips end to end, one clip at a time (never commit a clip, a frame or a run):
# for each clip fit-video (every 5th kept frame of 6 fps held out), train --preset standard (the
# video's size, longer side up to 512 px), eval on the held-out frames at the training size,
# pack; then one table of all clips in OUT/clips.md.
#
#   scripts/real-clips.sh LIST OUT [--threads N] [--train "key=value ..."] [--haha build/cli/haha]
#
# LIST: one clip a line, "NAME PATH [fit-video options...]"; blank lines and lines starting
# with # are skipped. Each clip writes OUT/NAME/fit, OUT/NAME/run (report.json, eval_sheet.png),
# OUT/NAME/avatar.glb, OUT/NAME/<step>.log and OUT/NAME/<step>.seconds. A finished step is
# reused, so a rerun resumes; a failed step stops its clip (OUT/NAME/failed says which and why)
# and the suite goes on with the next (a finished run is reused whatever --train says: give
# another OUT, with OUT/NAME/fit linked to reuse fits). Shared machine: nice -n 19 ...
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
list="" out="" threads="" train_keys="" haha="$repo/build/cli/haha"
die() { echo "real-clips: error: $1" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    --threads|--train|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in --threads) threads="$2" ;; --train) train_keys="$2" ;; --haha) haha="$2" ;; esac
      shift 2 ;;
    -*) die "$1: unknown option (usage: scripts/real-clips.sh LIST OUT [--threads N] [--train KEYS] [--haha PATH])" ;;
    *) if [ -z "$list" ]; then list="$1"; elif [ -z "$out" ]; then out="$1"; else die "$1: one LIST and one OUT only"; fi
       shift ;;
  esac
done
[ -n "$list" ] && [ -n "$out" ] || die "LIST OUT: missing (usage: scripts/real-clips.sh LIST OUT [--threads N] [--train KEYS] [--haha PATH])"
[ -r "$list" ] && [ ! -d "$list" ] || die "$list: not found"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"
[ -z "$threads" ] || case "$threads" in [1-9]|[1-9][0-9]) ;; *) die "--threads: '$threads' is not a number of threads" ;; esac
py=/usr/bin/python3
[ -x "$py" ] || py=python3
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
thr=()
[ -z "$threads" ] || thr=(--threads "$threads")

# Check the list before anything runs: names unique and plain, videos present.
names=()
while read -r name path _; do
  case "$name" in ''|'#'*) continue ;; esac
  case "$name" in *[!A-Za-z0-9._-]*) die "$list: clip name '$name' is not letters, digits, . _ -" ;; esac
  [ -n "$path" ] || die "$list: clip '$name' has no PATH"
  [ -e "$path" ] || die "$list: clip '$name': $path not found"
  for n in "${names[@]+"${names[@]}"}"; do [ "$n" != "$name" ] || die "$list: clip '$name' listed twice"; done
  names+=("$name")
done < "$list"
[ ${#names[@]} -gt 0 ] || die "$list: no clips"
mkdir -p "$out"
t0=$SECONDS
say() { echo "real-clips: [$1] $2 ($((SECONDS - t0)) s)"; }

# step CLIP DIR STEP CMD...: runs CMD with its output in DIR/STEP.log, its wall time in
# DIR/STEP.seconds; on failure one line naming the clip and the step, DIR/failed, status 1.
step() {
  local clip="$1" dir="$2" name="$3"; shift 3
  local s=$EPOCHREALTIME rc=0
  say "$clip" "$name: ${*#"$repo/"}"
  "$@" > "$dir/$name.log" 2>&1 || rc=$?
  if [ $rc -ne 0 ]; then
    local why
    # The error line if the tool wrote one, else its last line; a signal by name.
    why="$(grep -aiE 'error|exception|what\(\)|abort|fault' "$dir/$name.log" | tail -n 1 | cut -c1-300)"
    [ -n "$why" ] || why="$(grep -av -e '^[[:space:]]*$' -e '^Run with --help' "$dir/$name.log" | tail -n 1 | cut -c1-300)"
    local how="exit $rc"
    [ $rc -le 128 ] || how="killed by signal $(kill -l $((rc - 128)) 2>/dev/null || echo $((rc - 128)))"
    echo "$name: $how: ${why:-no output}" > "$dir/failed"
    echo "real-clips: FAILED: clip $clip, step $name ($how): ${why:-no output} (log $dir/$name.log)" >&2
    return 1
  fi
  echo "$EPOCHREALTIME $s" | awk '{ printf "%.1f\n", $1 - $2 }' > "$dir/$name.seconds"
}

# run_clip NAME PATH [fit-video options...]
run_clip() {
  local clip="$1" video="$2"; shift 2
  local d="$out/$clip"
  mkdir -p "$d"
  rm -f "$d/failed"
  if [ -f "$d/fit/fit_report.json" ] && [ -f "$d/fit/dataset.json" ]; then
    say "$clip" "fit-video: reusing $d/fit"
  else
    rm -rf "$d/fit" "$d/run" "$d/avatar.glb"
    step "$clip" "$d" fit-video "$haha" fit-video "$video" --out "$d/fit" --fps 6 --test-every 5 \
      "${thr[@]+"${thr[@]}"}" "$@" || return 0
  fi
  if [ -f "$d/run/train_summary.json" ] && [ -f "$d/run/avatar.npz" ]; then
    say "$clip" "train: reusing $d/run"
  else
    rm -rf "$d/run" "$d/avatar.glb"
    # shellcheck disable=SC2086  # the keys are a word list on purpose
    step "$clip" "$d" train "$haha" train --data "$d/fit" --out "$d/run" --preset standard \
      "${thr[@]+"${thr[@]}"}" $train_keys || return 0
  fi
  if [ -f "$d/run/report.json" ] && [ -f "$d/run/eval_sheet.png" ]; then
    say "$clip" "eval: reusing $d/run/report.json"
  else
    step "$clip" "$d" eval "$haha" eval --run "$d/run" "${thr[@]+"${thr[@]}"}" || return 0
  fi
  if [ -s "$d/avatar.glb" ] && [ "$d/avatar.glb" -nt "$d/run/avatar.npz" ]; then
    say "$clip" "pack: reusing $d/avatar.glb"
  else
    step "$clip" "$d" pack "$haha" pack "$d/run" --out "$d/avatar.glb" "${thr[@]+"${thr[@]}"}" || return 0
  fi
  say "$clip" "done"
}

while read -r name path rest; do
  case "$name" in ''|'#'*) continue ;; esac
  # shellcheck disable=SC2086  # the fit-video options are a word list on purpose
  run_clip "$name" "$path" $rest < /dev/null
done < "$list"

# The table: fit_report.json (fit), run/report.json (eval), run/train_summary.json, the .glb.
"$py" - "$out" "${names[@]}" <<'EOF'
import json, os, sys
out, names = sys.argv[1], sys.argv[2:]
def load(p):
    try:
        with open(p) as f: return json.load(f)
    except (OSError, ValueError): return None
def mins(d, step):
    try:
        with open(os.path.join(d, step + ".seconds")) as f: m = float(f.read()) / 60
        return "%.1f" % m if m >= 0.095 else "%.2f" % m
    except (OSError, ValueError): return "-"
rows, sheets = [], []
for n in names:
    d = os.path.join(out, n)
    fit, rep = load(os.path.join(d, "fit", "fit_report.json")), load(os.path.join(d, "run", "report.json"))
    why = None
    if os.path.exists(os.path.join(d, "failed")):
        with open(os.path.join(d, "failed")) as f: why = f.read().strip()
    frames = "%d/%d" % (fit["train"], fit["test"]) if fit else "-"
    kp = "%.1f" % fit["mean_reprojection_px"] if fit else "-"
    iou = "%.3f" % fit["mean_silhouette_iou"] if fit else "-"
    size, v, kept = "-", {}, "-"
    if rep:
        size = "%dx%d" % tuple(rep["resolution"])
        v = {x["name"]: x for x in rep["variants"]}
        full, haha = v.get("full Gaussians"), v.get("HAHA filtered")
        if full and haha and full["gaussians"]:
            kept = "%.0f %% (%d of %d)" % (100.0 * haha["gaussians"] / full["gaussians"], haha["gaussians"], full["gaussians"])
    def ps(name):
        x = v.get(name)
        return "%.2f / %.3f" % (x["psnr"], x["ssim"]) if x else "-"
    glb = os.path.join(d, "avatar.glb")
    size_b = "{:,}".format(os.path.getsize(glb)) if os.path.isfile(glb) else "-"
    t = " / ".join(mins(d, s) for s in ("fit-video", "train", "eval", "pack"))
    status = "failed: " + why if why else ("done" if os.path.isfile(glb) and rep else "not finished")
    rows.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
        n, frames, kp, iou, size, ps("mesh only"), ps("full Gaussians"), ps("HAHA filtered"), kept, size_b, t, status))
    if os.path.isfile(os.path.join(d, "run", "eval_sheet.png")):
        sheets.append("- %s: [eval_sheet.png](%s/run/eval_sheet.png), fit [fit_contact_sheet.png](%s/fit/fit_contact_sheet.png)" % (n, n, n))
with open(os.path.join(out, "clips.md"), "w") as f:
    f.write("# Real clips\n\nfit-video --fps 6 --test-every 5, train --preset standard, eval on the held-out frames at the "
            "training size (PSNR dB / SSIM, black background), pack with its defaults.\n\n")
    f.write("| clip | frames train/test | fit keypoint px | fit silhouette IoU | scored size | mesh PSNR / SSIM | "
            "full PSNR / SSIM | HAHA PSNR / SSIM | Gaussians kept (HAHA of full) | .glb bytes | "
            "minutes fit / train / eval / pack | status |\n")
    f.write("|" + "---|" * 12 + "\n")
    f.write("\n".join(rows) + "\n\nContact sheets:\n\n" + ("\n".join(sheets) if sheets else "(none)") + "\n")
EOF
say suite "wrote $out/clips.md"
grep '^| ' "$out/clips.md"
