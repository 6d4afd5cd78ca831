#!/usr/bin/env python3
"""Total GPU time per kernel from `ncu --metrics gpu__time_duration.sum --print-summary
per-kernel` output (stdin): one line per kernel and grid size, largest first, with its share,
call count and mean. Used by scripts/gpu-measure.sh (part `kernels`)."""
import re
import sys

HEAD = re.compile(r'\s+(\S.*?)\(.*\) \((\d+), \d+, \d+\)x\(\d+, \d+, \d+\), .*Invocations (\d+)')
UNIT = {'ns': 1e-3, 'us': 1.0, 'usecond': 1.0, 'ms': 1e3, 'msecond': 1e3}
rows, name = [], None
for line in sys.stdin:
    m = HEAD.match(line)
    if m:
        name, calls = f'{m.group(1)} (grid {m.group(2)})', int(m.group(3))
    elif name and 'gpu__time_duration.sum' in line:
        f = line.split()
        mean = float(f[-1]) * UNIT.get(f[1], 1.0)
        rows.append((calls * mean, calls, mean, name.replace('haha::<unnamed>::', '')))
        name = None
total = sum(r[0] for r in rows) or 1.0
print(f'{"total us":>10} {"share":>6} {"calls":>6} {"mean us":>9}  kernel   (all: {total:.0f} us)')
for t, calls, mean, n in sorted(rows, reverse=True):
    print(f'{t:10.0f} {100 * t / total:5.1f}% {calls:6d} {mean:9.1f}  {n[:100]}')
