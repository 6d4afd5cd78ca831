#!/usr/bin/env bash
# The clothed surface against the bare body on one dataset: trains it twice with the same
# preset, once as the preset has it and once with the clothed-surface fit (s0.surface.*),
# evaluates both (held-out frames at the training size) and prints one table: mesh / full
# Gaussians / HAHA PSNR and SSIM, Gaussians kept, training seconds, and the fit's displacement.
#
#   scripts/measure-clothed-surface.sh DATA OUT [--preset standard] [--surface "key=value ..."]
#        [--train "key=value ..."] [--haha build/cli/haha]
#
# --surface: the keys that turn the fit on (default "s0.surface.steps=2000"); --train: keys for
# both runs. Runs are OUT/bare and OUT/surface; a finished run is reused. Needs python3.
set -euo pipefail
repo="$(cd "$(dirname "$0")/.." && pwd)"
data="" out="" preset="standard" surface="s0.surface.steps=2000" train="" haha="$repo/build/cli/haha"
die() { echo "haha: error: $1" >&2; exit 1; }
while [ $# -gt 0 ]; do
  case "$1" in
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    --preset|--surface|--train|--haha)
      [ $# -ge 2 ] || die "$1: needs a value"
      case "$1" in --preset) preset="$2" ;; --surface) surface="$2" ;; --train) train="$2" ;; --haha) haha="$2" ;; esac
      shift 2 ;;
    -*) die "$1: unknown option" ;;
    *) if [ -z "$data" ]; then data="$1"; elif [ -z "$out" ]; then out="$1"; else die "$1: one DATA and one OUT only"; fi
       shift ;;
  esac
done
[ -n "$data" ] && [ -n "$out" ] || die "DATA OUT: missing (usage: scripts/measure-clothed-surface.sh DATA OUT [options])"
[ -f "$data/dataset.json" ] || die "$data: not a dataset (no dataset.json)"
[ -x "$haha" ] || die "$haha: not built (cmake --build build --target haha, or give --haha)"
command -v python3 >/dev/null 2>&1 || die "python3: not installed"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
mkdir -p "$out"
for variant in bare surface; do
  run="$out/$variant"
  if [ ! -f "$run/report.json" ]; then
    rm -rf "$run"
    keys=($train)
    [ "$variant" = bare ] || keys+=($surface)
    echo "== $variant: haha train --preset $preset ${keys[*]}"
    "$haha" train --data "$data" --out "$run" --preset "$preset" "${keys[@]}" > "$out/$variant.train.log"
    grep -E "clothed surface:|^done" "$out/$variant.train.log" || true
    "$haha" eval --run "$run" > "$out/$variant.eval.log"
  fi
done
python3 - "$out" <<'EOF'
import json, sys, os
out = sys.argv[1]
print("| run | mesh | full Gaussians | HAHA | HAHA - full | kept | train s (fit included) | displacement mean / p95 / max mm |")
print("|---|---:|---:|---:|---:|---:|---:|---:|")
for variant in ("bare", "surface"):
    r = json.load(open(os.path.join(out, variant, "report.json")))
    v = {x["name"]: x for x in r["variants"]}
    rows = r["variants"]
    mesh, full, haha = rows[0], rows[1], rows[3]
    s = json.load(open(os.path.join(out, variant, "train_summary.json")))
    cs = s.get("clothed_surface")
    disp = "%.1f / %.1f / %.1f" % (cs["mean_mm"], cs["p95_mm"], cs["max_mm"]) if cs else "-"
    kept = haha["gaussians"] / max(1, full["gaussians"])
    print("| %s | %.2f / %.3f | %.2f / %.3f | %.2f / %.3f | %+.2f | %.1f%% | %.1f | %s |" % (
        variant, mesh["psnr"], mesh["ssim"], full["psnr"], full["ssim"], haha["psnr"], haha["ssim"],
        haha["psnr"] - full["psnr"], 100 * kept, s["train_seconds"] + (cs["seconds"] if cs else 0), disp))
EOF
