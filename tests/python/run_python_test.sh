#!/usr/bin/env bash
# Runs a Python test script with the given interpreter, or skips (exit 77, CTest's
# SKIP_RETURN_CODE) with the reason when the interpreter or its numpy is missing.
#   run_python_test.sh PYTHON SCRIPT [ARGS...]
set -euo pipefail
python="$1"
shift
[ -x "$python" ] || { echo "SKIP: $python not found (apt-get install python3 python3-numpy, or set HAHA_PYTHON3)"; exit 77; }
"$python" -c "import numpy" >/dev/null 2>&1 || { echo "SKIP: $python has no numpy (apt-get install python3-numpy)"; exit 77; }
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
exec "$python" "$@"
