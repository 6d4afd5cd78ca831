#!/usr/bin/env python3
"""Is the fitted avatar's gap in the avatar or in the test-time pose optimisation? Evaluate
both avatars of a `scripts/measure-fit-video.sh` output on their own training frames, posed
with the poses stage 1 refined for those frames (RUN/smplx_refined.npz), against the true
(synthetic, lossless) pixels (docs/fit-video.md, "Where the pose error sits").

    /usr/bin/python3 scripts/fit-train-frames.py OUT [--haha build/cli/haha] [--eval "..."]

OUT: a measure-fit-video.sh output (OUT/run_fit, OUT/run_exact, OUT/fit, OUT/synth_split,
OUT/synth). Makes OUT/train_frames_{exact,fit,own}: the run's dataset with the training frames
as the test split, their parameters replaced by the refined ones and (for the fitted run)
their images and masks by the synth PNGs; evaluates each run there with --eval (default
`--antialias --tto-steps 0`: the refined poses as they are; `haha eval --out` puts the
report in OUT/train_frames_*/eval, so the runs keep their own) and prints the HAHA rows.
Also `own`: the fitted avatar against its own training targets (the video frames and the
keypoint tool's masks). First it prints how far the training frames' poses are from the
truth (the mean rotation between fitted and true local joint rotations over the 21 body
joints, and the shoulders'): the fit's, and both runs' after stage 1's refinement. Needs
numpy.
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rotation import log_rotation, rodrigues  # noqa: E402
from script_args import die, parse_args  # noqa: E402


def joint_errors(truth, body_pose):
    """Mean local rotation error (degrees) of body_pose against truth (both the training
    frames' body poses, in order): all 21 joints, left shoulder, right shoulder."""
    err = np.zeros((len(truth), 21))
    for n in range(len(truth)):
        for j in range(21):
            a = rodrigues(truth[n][3 * j:3 * j + 3].astype(np.float64))
            b = rodrigues(np.asarray(body_pose[n]).reshape(-1)[3 * j:3 * j + 3].astype(np.float64))
            err[n, j] = np.degrees(np.linalg.norm(log_rotation(a.T @ b)))
    return err.mean(), err[:, 15].mean(), err[:, 16].mean()


def make(out, which, target):
    """OUT/train_frames_TARGET from run_WHICH's dataset; target: fit | exact | own."""
    src = os.path.join(out, 'synth_split' if which == 'exact' else 'fit')
    d = os.path.join(out, 'train_frames_' + target)
    shutil.rmtree(d, ignore_errors=True)
    shutil.copytree(src, d, ignore=shutil.ignore_patterns('work'))
    meta = json.load(open(os.path.join(d, 'dataset.json')))
    params = dict(np.load(os.path.join(d, meta['smplx'])))
    refined = np.load(os.path.join(out, 'run_' + which, 'smplx_refined.npz'))
    train = [n for n, f in enumerate(meta['frames']) if f['split'] == 'train']
    if refined['body_pose'].shape[0] != len(train):
        die('%s: %d refined frames, the dataset has %d training frames'
            % (os.path.join(out, 'run_' + which, 'smplx_refined.npz'), refined['body_pose'].shape[0], len(train)))
    for k in refined.keys():
        if k in params:
            params[k][train] = refined[k].reshape(params[k][train].shape)
    for n, f in enumerate(meta['frames']):
        f['split'] = 'test' if n in train else 'train'
        if target == 'fit':  # the synth PNGs: premultiplied on black with their soft masks
            for folder, field in (('images', 'image'), ('masks', 'mask')):
                shutil.copyfile(os.path.join(out, 'synth', folder, '%06d.png' % f['source_index']),
                                os.path.join(d, f[field]))
    if target == 'fit':
        meta['premultiplied'] = True
    meta.pop('smplx_true', None)  # params.npz now holds the refined poses
    json.dump(meta, open(os.path.join(d, 'dataset.json'), 'w'), indent=1)
    np.savez(os.path.join(d, meta['smplx']), **params)
    return d


def main(argv):
    opts = {'--haha': os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'build', 'cli', 'haha'),
            '--eval': '--antialias --tto-steps 0'}
    pos = parse_args(argv, opts, __doc__)
    if len(pos) != 1:
        die('usage: fit-train-frames.py OUT (see --help)')
    out = pos[0]
    for sub in ('fit/dataset.json', 'synth_split/dataset.json', 'run_fit/smplx_refined.npz',
                'run_exact/smplx_refined.npz'):
        if not os.path.isfile(os.path.join(out, sub)):
            die('%s: not a measure-fit-video.sh output (no %s)' % (out, sub))
    fit_meta = json.load(open(os.path.join(out, 'fit', 'dataset.json')))
    fit_pose = np.load(os.path.join(out, 'fit', fit_meta['smplx']))['body_pose']
    train = [n for n, f in enumerate(fit_meta['frames']) if f['split'] == 'train']
    synth = json.load(open(os.path.join(out, 'synth', 'dataset.json')))
    truth = np.load(os.path.join(out, 'synth', synth.get('smplx_true') or synth['smplx']))['body_pose']
    truth = truth[[fit_meta['frames'][n]['source_index'] for n in train]]  # frame i of the video is synth frame i
    for what, pose in (('the fit', fit_pose[train]),
                       ('fitted run, refined', np.load(os.path.join(out, 'run_fit', 'smplx_refined.npz'))['body_pose']),
                       ('exact run, refined', np.load(os.path.join(out, 'run_exact', 'smplx_refined.npz'))['body_pose'])):
        print('joint rotation error against the truth, training frames, %s: %.1f deg (shoulders %.1f / %.1f)'
              % ((what,) + joint_errors(truth, pose)))
    env = dict(os.environ, OMP_WAIT_POLICY=os.environ.get('OMP_WAIT_POLICY', 'passive'))
    for which, target, what in (('exact', 'exact', 'exact avatar, true pixels'),
                                ('fit', 'fit', 'fitted avatar, true pixels'),
                                ('fit', 'own', 'fitted avatar, its own targets')):
        d = make(out, which, target)
        table = subprocess.run([opts['--haha'], 'eval', '--run', os.path.join(out, 'run_' + which), '--data', d,
                                '--out', os.path.join(d, 'eval')]
                               + opts['--eval'].split(), capture_output=True, text=True, env=env, check=True).stdout
        open(os.path.join(d, 'eval.txt'), 'w').write(table)
        rows = [line.strip() for line in table.splitlines() if line.strip().startswith('HAHA filtered')]
        print('training frames, %s: %s' % (what, rows[0] if rows else '(no HAHA row: see %s/eval.txt)' % d))


if __name__ == '__main__':
    main(sys.argv[1:])
