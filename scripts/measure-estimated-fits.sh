#!/usr/bin/env bash
# Estimated fits with no settings given: does `haha train` + `haha eval` pick the settings
# for estimated fits from dataset.json by themselves?
#
#   scripts/measure-estimated-fits.sh OUT [--fit-noise-pose 0.05] [--fit-noise-transl 0.02]
#        [--preset tiny|paper] [--haha build/cli/haha]
#
# 1. haha synth --out OUT/data with fit noise (0.05 rad on every pose value, 2 cm on transl
#    by default), which flags the fits "estimated" in dataset.json (0 and 0: "exact");
# 2. removes the true fits (OUT/data/smplx/params_true.npz and dataset.json's "smplx_true"),
#    so the dataset looks like a real one;
# 3. haha train --data OUT/data --out OUT/run --preset tiny and haha eval --run OUT/run, with
#    no key or flag: the run's config.json holds what training picked;
# 4. prints the eval table, the fits line of training and the HAHA filtered PSNR against the
#    bar: within 1.0 dB of the exact-fit sample with the defaults (28.32 dB, docs/results.md).
# About 5 minutes at the tiny preset on two cores. Needs python3 (the JSON edit of step 2).
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
out="" haha="$repo/build/cli/haha" preset="tiny" noise_pose=0.05 noise_transl=0.02
die() { echo "haha: error: $1" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    --fit-noise-pose|--fit-noise-transl|--preset|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in
        --fit-noise-pose) noise_pose="$2" ;; --fit-noise-transl) noise_transl="$2" ;;
        --preset) preset="$2" ;; --haha) haha="$2" ;;
      esac
      shift 2 ;;
    -*) die "$1: unknown option" ;;
    *) [ -z "$out" ] || die "$1: only one OUT folder"; out="$1"; shift ;;
  esac
done
[ -n "$out" ] || die "OUT: missing (usage: scripts/measure-estimated-fits.sh OUT [--fit-noise-pose R] ...)"
command -v python3 >/dev/null 2>&1 || die "python3: not installed (apt-get install python3)"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"
[ ! -e "$out/run" ] || die "$out/run: exists (a run is never overwritten; choose another OUT or remove it)"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
t0=$SECONDS
mkdir -p "$out" || die "$out: cannot create the folder"

echo "== synth (fit noise $noise_pose rad, $noise_transl m) -> $out/data"
"$haha" synth --out "$out/data" --fit-noise-pose "$noise_pose" --fit-noise-transl "$noise_transl"
rm -f "$out/data/smplx/params_true.npz"
python3 - "$out/data/dataset.json" <<'EOF'
import json, sys
path = sys.argv[1]
with open(path) as f:
    d = json.load(f)
d.pop("smplx_true", None)
with open(path + ".tmp", "w") as f:
    json.dump(d, f, indent=1)
    f.write("\n")
import os
os.replace(path + ".tmp", path)
print("dataset.json: fits =", d.get("fits", "(not given)") + ", true fits removed")
EOF

echo "== train --preset $preset (no keys)"
"$haha" train --data "$out/data" --out "$out/run" --preset "$preset" | tee "$out/train.log"
echo "== eval (no flags)"
"$haha" eval --run "$out/run" | tee "$out/eval.log"

python3 - "$out/run/report.json" "$out/train.log" <<'EOF'
import json, sys
r = json.load(open(sys.argv[1]))
fits = [l.rstrip() for l in open(sys.argv[2]) if l.startswith("fits: ")]
haha = [v for v in r["variants"] if v["name"] == "HAHA filtered"][0]
print()
print("training picked:", fits[0] if fits else "(no fits line)")
print("eval: test-time pose optimisation %d steps, antialias %s" % (r["tto_steps"], str(r["antialias"]).lower()))
psnr = haha["psnr"]
print("HAHA filtered %.2f dB; bar >= 27.32 dB (exact-fit sample with the defaults 28.32 dB - 1.0): %s"
      % (psnr, "met" if psnr >= 27.32 else "NOT met"))
EOF
echo "$((SECONDS - t0)) s in all; run: $out/run (report.md, config.json)"
