"""The train-and-evaluate step the oracle scripts share (fit-oracle.py, pose-noise-oracle.py):
the settings scripts/measure-fit-video.sh uses, so their rows sit beside its rows."""
import os
import subprocess

HERE = os.path.dirname(os.path.abspath(__file__))

# Options (with measure-fit-video.sh's defaults) each oracle script accepts.
TRAIN_EVAL_OPTIONS = {'--haha': os.path.join(HERE, '..', 'build', 'cli', 'haha'), '--preset': 'tiny',
                      '--train': 's0.photo.steps=6000 s1.lr.pose=0.005', '--eval': '--antialias --tto-steps 100'}


def train_and_evaluate(opts, train_data, eval_data, model, base):
    """Trains base/run on train_data (log: base/train.log), evaluates it on eval_data and
    returns the eval table (also written to base/eval.txt)."""
    haha, run = opts['--haha'], os.path.join(base, 'run')
    env = dict(os.environ, OMP_WAIT_POLICY=os.environ.get('OMP_WAIT_POLICY', 'passive'))
    with open(os.path.join(base, 'train.log'), 'w') as log:
        subprocess.run([haha, 'train', '--data', train_data, '--model', model, '--out', run, '--preset',
                        opts['--preset']] + opts['--train'].split(),
                       stdout=log, stderr=subprocess.STDOUT, env=env, check=True)
    table = subprocess.run([haha, 'eval', '--run', run, '--data', eval_data] + opts['--eval'].split(),
                           capture_output=True, text=True, env=env, check=True).stdout
    open(os.path.join(base, 'eval.txt'), 'w').write(table)
    return table
