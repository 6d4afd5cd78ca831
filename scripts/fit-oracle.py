#!/usr/bin/env python3
"""Where the avatar gap of `haha fit-video` comes from: train and evaluate the fitted
dataset with some of its parts replaced by the truth (docs/fit-video.md, "What the gap is
made of").

    /usr/bin/python3 scripts/fit-oracle.py OUT NAME PART... [--haha build/cli/haha]
                           [--preset tiny|paper] [--train "key=value ..."] [--eval "..."]

OUT: a scripts/measure-fit-video.sh output (OUT/fit, OUT/fit_eval, OUT/synth). Makes
OUT/oracle_NAME/{train,eval}: OUT/fit and OUT/fit_eval with PART... taken from the true fits
(OUT/synth's smplx_true or smplx), trains the tiny preset (--preset) on the first with the
same settings as measure-fit-video.sh and evaluates on the second, then prints the HAHA and
full-Gaussian rows. PART:
  orient      the global orient (turned into the fit's camera: the truth's camera rotation
              times its orient; translation stays fitted)
  body        the 21 body joints
  arms        of those only the shoulders and elbows (legs: hips, knees, ankles, feet;
              torso: spine, neck, collars, head; the other joints stay fitted)
  hands       both hands and the jaw
  betas       the shape
  camera      the true camera, and with it the true orient and transl as they are (use with
              every pose part: the fitted transl belongs to the fitted camera)
  transl      the translation (only meaningful with camera)
  masks       the true masks of the training frames (instead of the keypoint tool's)
  images      the true (PNG, lossless) images of the training frames
A pose PART may end in @train or @test: only those frames take the truth. Needs numpy.
"""
import json
import os
import shutil
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from oracle_run import TRAIN_EVAL_OPTIONS, train_and_evaluate  # noqa: E402
from rotation import log_rotation, rodrigues  # noqa: E402
from script_args import die, parse_args  # noqa: E402

POSE_PARTS = {'orient': ['global_orient'], 'body': ['body_pose'],
              'hands': ['left_hand_pose', 'right_hand_pose', 'jaw_pose'], 'betas': ['betas'],
              'transl': ['transl']}
FILE_PARTS = {'masks': ('masks', 'mask'), 'images': ('images', 'image')}
# Groups of body_pose's 21 joints (SMPL-X order without the pelvis).
JOINT_PARTS = {'arms': [15, 16, 17, 18], 'legs': [0, 1, 3, 4, 6, 7, 9, 10], 'torso': [2, 5, 8, 11, 12, 13, 14]}


def copy_cropped(src, dst, crop):
    """A synth PNG as the fitted dataset holds it: cut to its source_crop [x0, y0, w, h] when
    fit-video cropped (ffmpeg's crop filter, lossless, the PNG's pixel format kept)."""
    if not crop:
        shutil.copyfile(src, dst)
        return
    subprocess.run(['ffmpeg', '-nostdin', '-y', '-v', 'error', '-i', src, '-vf',
                    'crop=%d:%d:%d:%d' % (crop[2], crop[3], crop[0], crop[1]), '-frames:v', '1', dst], check=True)


def main(argv):
    opts = dict(TRAIN_EVAL_OPTIONS)
    pos = parse_args(argv, opts, __doc__)
    if len(pos) < 3:
        die('usage: fit-oracle.py OUT NAME PART... (see --help)')
    out, name, parts = pos[0], pos[1], pos[2:]
    for sub in ('fit', 'fit_eval', 'synth'):
        if not os.path.isfile(os.path.join(out, sub, 'dataset.json')):
            die('%s: not a measure-fit-video.sh output (no %s/dataset.json)' % (out, sub))
    keys, only, files, camera, joints = [], {}, [], False, {}
    for p in parts:
        base, _, split = p.partition('@')
        if split not in ('', 'train', 'test'):
            die('%s: the split after @ must be train or test' % p)
        if base == 'camera':
            camera = True
        elif base in FILE_PARTS:
            files.append(base)
        elif base in JOINT_PARTS:
            for j in JOINT_PARTS[base]:
                joints[j] = split
        elif base in POSE_PARTS:
            for k in POSE_PARTS[base]:
                keys.append(k)
                if split:
                    only[k] = split
        else:
            die('%s: unknown part (orient body arms legs torso hands betas camera transl masks images)' % p)
    if joints and 'body_pose' in keys:
        die('body already holds every joint: give it or arms / legs / torso')

    synth = json.load(open(os.path.join(out, 'synth', 'dataset.json')))
    truth = np.load(os.path.join(out, 'synth', synth.get('smplx_true') or synth['smplx']))
    R_cam = np.array(synth['camera']['world_to_camera'])[:3, :3]
    frames = json.load(open(os.path.join(out, 'fit', 'dataset.json')))['frames']
    fitted = dict(np.load(os.path.join(out, 'fit', 'smplx', 'params.npz')))
    for k in keys:
        rows = []
        for n, f in enumerate(frames):
            i = f['source_index']  # decoded frame i of the video is synth frame i
            if only.get(k, f['split']) != f['split']:
                rows.append(fitted[k][n])
            elif k == 'global_orient' and not camera:
                rows.append(log_rotation(R_cam @ rodrigues(truth[k][i].astype(np.float64))))
            else:
                rows.append(truth[k][i].reshape(fitted[k][n].shape))
        fitted[k] = np.array(rows, np.float32)
    for n, f in enumerate(frames):
        for j, split in joints.items():
            if split in ('', f['split']):
                fitted['body_pose'][n][3 * j:3 * j + 3] = truth['body_pose'][f['source_index']][3 * j:3 * j + 3]

    crop = json.load(open(os.path.join(out, 'fit', 'dataset.json'))).get('source_crop')  # [x0, y0, w, h]
    base = os.path.join(out, 'oracle_' + name)
    for sub, src in (('train', 'fit'), ('eval', 'fit_eval')):
        d = os.path.join(base, sub)
        shutil.rmtree(d, ignore_errors=True)
        shutil.copytree(os.path.join(out, src), d, ignore=shutil.ignore_patterns('work'))
        np.savez(os.path.join(d, 'smplx', 'params.npz'), **fitted)
        for part in files:
            folder, field = FILE_PARTS[part]
            for f in frames:
                copy_cropped(os.path.join(out, 'synth', folder, '%06d.png' % f['source_index']),
                             os.path.join(d, f[field]), crop)
        if camera:
            meta = json.load(open(os.path.join(d, 'dataset.json')))
            meta['camera'] = json.loads(json.dumps(synth['camera']))
            if crop:  # the cut moves the principal point
                meta['camera']['K'][0][2] -= crop[0]
                meta['camera']['K'][1][2] -= crop[1]
            json.dump(meta, open(os.path.join(d, 'dataset.json'), 'w'), indent=1)

    table = train_and_evaluate(opts, os.path.join(base, 'train'), os.path.join(base, 'eval'),
                               os.path.join(out, 'synth', 'body_model.npz'), base)
    rows = [line.strip() for line in table.splitlines() if line.strip().startswith(('HAHA filtered', 'full Gaussians'))]
    print('%s (%s): %s' % (name, ' '.join(parts), ' | '.join(rows[:2])))


if __name__ == '__main__':
    main(sys.argv[1:])
