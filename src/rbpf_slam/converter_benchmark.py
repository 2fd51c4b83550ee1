"""Conversion speed of the log converters against the time span of the logs: how many times faster than
real time each conversion runs.

Runs, as a user would (a new process each, wall-clock time including start-up):
  - carmen_to_bag on the Intel Research Lab log (DATA/carmen/intel-corrected.log.gz), whole;
  - ese650_to_bag on an ESE 650 run (default 20) with its encoders and IMU, and with a Hokuyo file of the
    real layout and size (1081 beams at 40 Hz over the run; the real ones are not shipped) that this
    script writes first, so the figure includes the largest input such a run has.

DATA is --data DIR or, without it, the environment variable RBPF_SLAM_DATA: the directory holding the
data sets (carmen/, ese650/, ...).

Example:
  RBPF_SLAM_DATA=path/to/data rosrun rbpf_slam converter_benchmark
  scripts/converter_benchmark --data path/to/data --run 21 --keep /tmp/bags
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time

from rbpf_slam import atomic, paths

PROG = 'converter_benchmark'


def bag_span(path):
    import rosbag
    with rosbag.Bag(path) as bag:
        return bag.get_end_time() - bag.get_start_time()


def write_hokuyo(path, encoders_path):
    """A Hokuyo<N>.mat in the data set's layout (struct Hokuyo0: ranges 1081 x S m, angles 1081 x 1 rad,
    ts 1 x S) at 40 Hz over the encoders' time span, with ranges of a room and some no-returns."""
    import numpy as np
    import scipy.io
    from rbpf_slam.ese650 import load_encoders
    ts, _ = load_encoders(encoders_path)
    stamps = np.arange(ts[0], ts[-1], 0.025)
    angles = np.radians(np.linspace(-135.0, 135.0, 1081))
    rng = np.random.default_rng(0)
    ranges = 3.0 + 2.0 * np.abs(np.cos(angles))[:, None] + rng.normal(0, 0.01, (1081, len(stamps)))
    ranges[rng.random(ranges.shape) < 0.05] = 0.0  # error codes / no return
    with atomic.atomic_output(path) as tmp:
        scipy.io.savemat(tmp, {'Hokuyo0': {'ranges': ranges, 'angles': angles.reshape(-1, 1),
                                           'ts': stamps.reshape(1, -1)}})
    return len(stamps)


def _script(name):
    """The package's entry point NAME (rbpf_slam.paths.script); a UserError when there is none."""
    try:
        return paths.script(name)
    except ValueError as e:
        raise atomic.UserError(str(e))


def timed(cmd):
    started = time.monotonic()
    atomic.run_child(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.monotonic() - started


def table(rows):
    """The printed table (lines) of the rows (name, span [s], conversion time [s], bag size [bytes])."""
    lines = ['%-40s %10s %12s %12s %9s' % ('log', 'span [s]', 'convert [s]', 'x real time', 'bag [MB]')]
    for name, span, t, size in rows:
        lines.append('%-40s %10.1f %12.2f %12.0f %9.1f' % (name, span, t, span / t, size / 1e6))
    lines.append('(wall-clock time of each command, Python start-up included; x real time = span / convert)')
    return lines


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr when a converter fails or is missing; 2 without a data
    directory."""
    return atomic.run_tool(PROG, _main, argv, errors=(subprocess.CalledProcessError,))


def _main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('--data', metavar='DIR', default=os.environ.get('RBPF_SLAM_DATA') or None,
                        help='the directory holding the data sets (default: $RBPF_SLAM_DATA)')
    parser.add_argument('--run', default='20', help='ESE 650 run number (default 20)')
    parser.add_argument('--keep', metavar='DIR', help='keep the bags in DIR (default: a temporary directory)')
    args = parser.parse_args(argv)
    if not args.data:
        print('converter_benchmark: no data directory: give --data DIR or set RBPF_SLAM_DATA', file=sys.stderr)
        return 2
    intel = os.path.join(args.data, 'carmen', 'intel-corrected.log.gz')
    ese = os.path.join(args.data, 'ese650')
    for path in (intel, os.path.join(ese, 'Encoders%s.mat' % args.run)):
        if not os.path.isfile(path):
            print('converter_benchmark: missing %s' % path, file=sys.stderr)
            return 1
    work = args.keep or tempfile.mkdtemp(prefix='converter_benchmark_')
    os.makedirs(work, exist_ok=True)
    python = sys.executable
    rows = []
    try:
        out = os.path.join(work, 'intel.bag')
        t = timed([python, _script('carmen_to_bag'), intel, '-o', out, '-q'])
        rows.append(('CARMEN Intel (whole log)', bag_span(out), t, os.path.getsize(out)))

        out = os.path.join(work, 'ese%s.bag' % args.run)
        t = timed([python, _script('ese650_to_bag'), ese, args.run, '-o', out, '-q'])
        rows.append(('ESE 650 run %s (encoders, IMU)' % args.run, bag_span(out), t, os.path.getsize(out)))

        hokuyo = os.path.join(work, 'Hokuyo%s.mat' % args.run)
        n = write_hokuyo(hokuyo, os.path.join(ese, 'Encoders%s.mat' % args.run))
        out = os.path.join(work, 'ese%s_hokuyo.bag' % args.run)
        t = timed([python, _script('ese650_to_bag'), ese, args.run, '--hokuyo', hokuyo, '-o', out, '-q'])
        rows.append(('ESE 650 run %s + Hokuyo (%d scans)' % (args.run, n), bag_span(out), t, os.path.getsize(out)))
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)

    for line in table(rows):
        print(line)
    return 0
