#!/usr/bin/env bash
# The layering check (run by ctest as `layering`): every #include "<layer>/..." in the
# sources must point at the same layer or one it may use. Layers, bottom up:
#   core < body < render < cuda < train;  render < synth;  io < data (also on synth);
#   fit (on data and train);  format;  runtime;  bench;  app;  cli (only app's drivers and the
#   types of their options);  tools (tools/train_bench: no I/O layer, it builds without them)
# runtime/ (libhaha_runtime.so) publishes "haha/haha_runtime.h"; samples/ may include
# nothing else of the project (they build against an installed prefix).
# Fails with one line per wrong-way include: file:line: <layer> may not include <layer>/.
set -euo pipefail
cd "$(dirname "$0")/.."

declare -A allowed=(
  [core]="core"
  [body]="core body"
  [render]="core body render"
  [cuda]="core body render cuda"
  [train]="core body render cuda train"
  [synth]="core body render synth"
  [io]="core body render io"
  [data]="core body render io synth data"
  [fit]="core body render train io data fit"
  [format]="core body render io format"
  [runtime]="core body render io format haha"
  [samples]="haha"
  [bench]="core body render cuda train io data format bench"
  [app]="core body render cuda train synth io data fit format bench app"
  [cli]="core body render train io data fit format app"
  [tools]="core body render cuda train synth"
)

layer_of() {  # path -> layer name
  case "$1" in
    libhaha/*) local rest=${1#libhaha/}; echo "${rest%%/*}" ;;
    format/*) echo format ;;
    runtime/*) echo runtime ;;
    samples/*) echo samples ;;
    bench/*) echo bench ;;
    app/*) echo app ;;
    cli/*) echo cli ;;
    tools/*) echo tools ;;
  esac
}

bad=0
while IFS= read -r file; do
  layer=$(layer_of "$file")
  [ -n "${allowed[$layer]+x}" ] || { echo "$file: unknown layer '$layer' (add it to scripts/check_layers.sh)"; bad=1; continue; }
  while IFS=: read -r line target; do
    case " ${allowed[$layer]} " in
      *" $target "*) ;;
      *) echo "$file:$line: $layer may not include $target/"; bad=1 ;;
    esac
  done < <(grep -n '^[[:space:]]*#[[:space:]]*include[[:space:]]*"[a-z_]*/' "$file" |
           sed -E 's/^([0-9]+):[[:space:]]*#[[:space:]]*include[[:space:]]*"([a-z_]+)\/.*/\1:\2/')
done < <(find libhaha format runtime bench app cli samples tools -name node_modules -prune -o -type f \
           \( -name '*.h' -o -name '*.c' -o -name '*.cpp' -o -name '*.cu' -o -name '*.cuh' \) -print | sort)

if [ "$bad" -ne 0 ]; then
  echo "check_layers: wrong-way includes found (see the layer list at the top of scripts/check_layers.sh)"
  exit 1
fi
echo "check_layers: every include points down or sideways"
