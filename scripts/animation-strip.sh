#!/usr/bin/env bash
# A strip of N frames of an avatar's own glTF animation (docs/results.md, "Animations in the
# file"): `haha render AVATAR --animation NAME` every EVERY frames at SIZE px, each frame cropped
# to a 200 x 300 window centred on the person (the clip may travel sideways), side by side, as
# a 256-colour PNG. Needs ffmpeg, node and format/js/node_modules (pngjs: npm ci --prefix format/js).
# Usage: scripts/animation-strip.sh HAHA AVATAR.glb NAME EVERY OUT.png [N=8] [SIZE=384]
set -euo pipefail
haha="$1" avatar="$2" name="$3" every="$4" out="$5" n="${6:-8}" size="${7:-384}"
root=$(cd "$(dirname "$0")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$haha" render "$avatar" --animation "$name" --every "$every" --max-frames "$n" --size "$size" --out "$work/frames" >/dev/null
mkdir -p "$work/crops"
for f in "$work"/frames/frame_*.png; do
  # Horizontal centre of the pixels that are not the white background.
  c=$(NODE_PATH="$root/format/js/node_modules" node -e '
    const p = require("pngjs").PNG.sync.read(require("fs").readFileSync(process.argv[1]));
    let x0 = p.width, x1 = 0;
    for (let y = 0; y < p.height; y++) for (let x = 0; x < p.width; x++) {
      const i = 4 * (y * p.width + x);
      if (p.data[i] < 245 || p.data[i + 1] < 245 || p.data[i + 2] < 245) { x0 = Math.min(x0, x); x1 = Math.max(x1, x); }
    }
    console.log(x1 >= x0 ? Math.round((x0 + x1) / 2) : p.width >> 1);' "$f")
  x=$(( c - 100 )); [ "$x" -lt 0 ] && x=0; [ $(( x + 200 )) -gt "$size" ] && x=$(( size - 200 ))
  ffmpeg -y -loglevel error -i "$f" -vf "crop=200:300:$x:$(( (size - 300) / 2 ))" "$work/crops/$(basename "$f")"
done
ffmpeg -y -loglevel error -i "$work/crops/frame_%05d.png" \
  -vf "tile=${n}x1,split[a][b];[a]palettegen=max_colors=256[p];[b][p]paletteuse=dither=none" -frames:v 1 "$out"
echo "$out: $n frames of '$name' every $every"
