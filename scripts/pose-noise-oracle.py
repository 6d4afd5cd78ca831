#!/usr/bin/env python3
"""How accurate must the poses be? Train and evaluate the exact dataset of a
scripts/measure-fit-video.sh output with noise of a known size added to its poses
(docs/fit-video.md, "How accurate the poses must be").

    /usr/bin/python3 scripts/pose-noise-oracle.py OUT NAME DEG [--smooth FRAMES] [--seed S]
                     [--parts body_pose,global_orient] [--haha build/cli/haha]
                     [--preset tiny|paper] [--train "key=value ..."] [--eval "..."]

OUT: a measure-fit-video.sh output (OUT/synth_split: the exact fits with the fitted run's
split). Makes OUT/noise_NAME: OUT/synth_split with every frame's joints of --parts (training
and held-out frames alike, as a fit's errors are) turned by a random rotation whose mean
angle is DEG degrees (axis-angle with independent normal components), optionally smoothed
over time with a Gaussian of --smooth frames (then rescaled to the same size: a slow error
like a fit's, not jitter). Trains it with the settings measure-fit-video.sh uses, evaluates
its test split, and prints the mean angle actually added and the HAHA row, to set beside the
script's exact and fitted rows. Needs numpy.
"""
import json
import os
import shutil
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from oracle_run import TRAIN_EVAL_OPTIONS, train_and_evaluate  # noqa: E402
from rotation import log_rotation, rodrigues  # noqa: E402
from script_args import die, parse_args  # noqa: E402

# Mean norm of a 3-vector of independent N(0, s^2) components: s * sqrt(8 / pi).
MEAN_NORM_PER_SIGMA = np.sqrt(8.0 / np.pi)


def noise(rng, frames, joints, mean_deg, smooth):
    n = rng.normal(size=(frames, joints, 3))
    if smooth > 0:
        t = np.arange(frames)
        kernel = np.exp(-0.5 * ((t[:, None] - t[None, :]) / smooth) ** 2)
        # Each smoothed value is a weighted sum of unit normals: divide by the weights' norm
        # to keep unit variance.
        n = np.einsum('ts,sjc->tjc', kernel, n) / np.sqrt((kernel ** 2).sum(1))[:, None, None]
    return n * np.radians(mean_deg) / MEAN_NORM_PER_SIGMA


def main(argv):
    opts = dict(TRAIN_EVAL_OPTIONS, **{'--smooth': '0', '--seed': '0', '--parts': 'body_pose'})
    pos = parse_args(argv, opts, __doc__)
    if len(pos) != 3:
        die('usage: pose-noise-oracle.py OUT NAME DEG (see --help)')
    out, name = pos[0], pos[1]
    try:
        mean_deg, smooth, seed = float(pos[2]), float(opts['--smooth']), int(opts['--seed'])
    except ValueError:
        die('DEG and --smooth must be numbers, --seed an integer')
    if not (0 <= mean_deg <= 90) or smooth < 0:
        die('DEG must be in [0, 90] and --smooth >= 0')
    src = os.path.join(out, 'synth_split')
    if not os.path.isfile(os.path.join(src, 'dataset.json')):
        die('%s: not a measure-fit-video.sh output (no synth_split/dataset.json)' % out)

    base = os.path.join(out, 'noise_' + name)
    data = os.path.join(base, 'data')
    shutil.rmtree(base, ignore_errors=True)
    shutil.copytree(src, data)
    meta = json.load(open(os.path.join(data, 'dataset.json')))
    params = dict(np.load(os.path.join(data, meta['smplx'])))
    rng = np.random.default_rng(seed)
    added = []
    for key in opts['--parts'].split(','):
        if key not in params or params[key].size % (3 * len(params[key])) != 0:
            die('%s: not a pose array of %s' % (key, meta['smplx']))
        rot = params[key].reshape(len(params[key]), -1, 3).astype(np.float64)
        dn = noise(rng, rot.shape[0], rot.shape[1], mean_deg, smooth)
        for f in range(rot.shape[0]):
            for j in range(rot.shape[1]):
                rot[f, j] = log_rotation(rodrigues(rot[f, j]) @ rodrigues(dn[f, j]))
                added.append(np.degrees(np.linalg.norm(dn[f, j])))
        params[key] = rot.reshape(params[key].shape).astype(np.float32)
    np.savez(os.path.join(data, meta['smplx']), **params)

    table = train_and_evaluate(opts, data, data, os.path.join(out, 'synth', 'body_model.npz'), base)
    rows = [line.strip() for line in table.splitlines() if line.strip().startswith('HAHA filtered')]
    print('%s (%s, %.2f deg mean added, smooth %g frames, seed %d): %s'
          % (name, opts['--parts'], np.mean(added), smooth, seed, rows[0] if rows else 'no HAHA row'))


if __name__ == '__main__':
    main(sys.argv[1:])
