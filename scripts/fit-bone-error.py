#!/usr/bin/env python3
"""How far a fitted dataset's training poses are from the truth, as the camera sees them:
each body bone's orientation (the chain of global orient and body joints, in camera axes)
against the true one, degrees, mean over the training frames (docs/fit-video.md,
"Photometric pose fit against a textured mesh"). Joint rotations alone would let a shoulder
and its collar trade rotations the images cannot tell apart; bone orientations do not.

    /usr/bin/python3 scripts/fit-bone-error.py FIT PARAMS TRUTH

FIT: a `haha fit-video` dataset (its dataset.json: camera, frames with split and
source_index); PARAMS: SMPL-X parameters of its frames (FIT/smplx/params.npz, all frames) or
of its training frames only (a run's smplx_refined.npz); TRUTH: the dataset with the true
fits (make-test-video.sh's synth/, smplx_true or smplx), frame i = decoded frame i. Prints
one line: mean bone error, the orient's, eight limb bones' and the shape's distance.
Needs numpy (Debian python3-numpy).
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rotation import rodrigues  # noqa: E402
from script_args import die, parse_args  # noqa: E402

PARENTS = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19]  # pelvis + 21 body joints
LIMBS = {16: 'l_shoulder', 17: 'r_shoulder', 18: 'l_elbow', 19: 'r_elbow', 1: 'l_hip', 2: 'r_hip', 4: 'l_knee',
         5: 'r_knee'}


def bones(params, i, R_cam):
    """Camera-axes orientation of the pelvis and the 21 body joints' bones of frame i."""
    G = [R_cam @ rodrigues(params['global_orient'][i].astype(np.float64))]
    for j in range(1, 22):
        G.append(G[PARENTS[j]] @ rodrigues(params['body_pose'][i][3 * (j - 1):3 * j].astype(np.float64)))
    return G


def angle(A, B):
    return np.degrees(np.arccos(np.clip((np.trace(A.T @ B) - 1) / 2, -1, 1)))


def main(argv):
    pos = parse_args(argv, {}, __doc__)
    if len(pos) != 3:
        die('usage: fit-bone-error.py FIT PARAMS TRUTH (see --help)')
    fit_dir, params_path, truth_dir = pos
    fit, truth = (json.load(open(os.path.join(d, 'dataset.json'))) for d in (fit_dir, truth_dir))
    P = np.load(params_path)
    T = np.load(os.path.join(truth_dir, truth.get('smplx_true') or truth['smplx']))
    R_fit = np.array(fit['camera']['world_to_camera'])[:3, :3]
    R_true = np.array(truth['camera']['world_to_camera'])[:3, :3]
    train = [k for k, f in enumerate(fit['frames']) if f['split'] == 'train']
    all_frames = P['global_orient'].shape[0] == len(fit['frames'])
    if not all_frames and P['global_orient'].shape[0] != len(train):
        die('%s: %d frames, neither all %d of %s nor its %d training frames' %
            (params_path, P['global_orient'].shape[0], len(fit['frames']), fit_dir, len(train)))
    errors = []
    for n, k in enumerate(train):
        mine = bones(P, k if all_frames else n, R_fit)
        true = bones(T, fit['frames'][k]['source_index'], R_true)
        errors.append([angle(a, b) for a, b in zip(mine, true)])
    e = np.array(errors)
    nb = P['betas'].shape[1]
    shape = np.linalg.norm(P['betas'][0] - T['betas'][0][:nb])
    print('mean bone %.2f deg | orient %.2f | %s | betas distance %.3f' %
          (e[:, 1:].mean(), e[:, 0].mean(), ' '.join('%s %.1f' % (LIMBS[j], e[:, j].mean()) for j in LIMBS), shape))


if __name__ == '__main__':
    main(sys.argv[1:])
