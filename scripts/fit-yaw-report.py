#!/usr/bin/env python3
"""Per-frame yaw of a `haha fit-video` result against the true fits, beside the yaw of the
keypoint tool's BlazePose world shoulder and hip lines (docs/fit-video.md, "Where the
orientation error comes from").

    /usr/bin/python3 scripts/fit-yaw-report.py OUT TRUTH

OUT: a fit-video output (its work/keypoints/keypoints/*.json, smplx/params.npz and
fit_report.json); TRUTH: the dataset with the true fits (smplx_true or smplx), its frames in
the video's order (make-test-video.sh's synth/). Yaw = the body's left axis in the camera's
x-z plane, degrees; errors are wrapped to [-180, 180). Needs numpy (Debian python3-numpy).
"""
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rotation import rodrigues  # noqa: E402


def dataset(path):
    d = json.load(open(os.path.join(path, 'dataset.json')))
    R = np.array(d['camera']['world_to_camera'])[:3, :3]
    params = d.get('smplx_true') or d['smplx']
    return R, np.load(os.path.join(path, params))['global_orient']


def yaw(v):
    return np.degrees(np.arctan2(v[2], v[0]))


def wrap(a):
    return (a + 180) % 360 - 180


def main():
    if len(sys.argv) != 3:
        sys.exit('usage: fit-yaw-report.py OUT TRUTH')
    out, truth = sys.argv[1], sys.argv[2]
    Rf, fit = dataset(out)
    Rt, true = dataset(truth)
    report = json.load(open(os.path.join(out, 'fit_report.json')))
    kp_dir = os.path.join(out, 'work', 'keypoints', 'keypoints')
    print(f'{"frame":>5} {"true":>7} {"fit":>7} {"world shoulders":>16} {"world hips":>11}   (errors, degrees)')
    errs = []
    kept = [f for f in report['frames'] if f.get('kept')]
    for f in kept:
        src, k = f['source_index'], f['dataset_frame']
        left = np.array([1.0, 0, 0])
        ty = yaw(Rt @ rodrigues(true[src]) @ left)
        fy = wrap(yaw(Rf @ rodrigues(fit[k]) @ left) - ty)
        w = json.load(open(os.path.join(kp_dir, f'{src:06d}.json'))).get('body_world')
        sy = hy = float('nan')
        if w:
            w = np.array(w)
            sy = wrap(yaw(w[11] - w[12]) - ty)  # BlazePose 11/12: left/right shoulder
            hy = wrap(yaw(w[23] - w[24]) - ty)  # 23/24: left/right hip
        errs.append((fy, sy, hy))
        print(f'{src:5d} {ty:7.1f} {fy:7.1f} {sy:16.1f} {hy:11.1f}')
    e = np.abs(np.array(errs))
    print('mean |error|: fit %.1f, world shoulders %.1f, world hips %.1f' % tuple(np.nanmean(e, axis=0)))


if __name__ == '__main__':
    main()
