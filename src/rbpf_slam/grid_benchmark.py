"""Accuracy, speed and memory of grid SLAM on one bag over several seeds, beside the bag's own odometry and,
optionally, other systems' trajectories of the same bag.

Runs `slam_bag --filter grid` once per seed (a new process each, one at a time unless --jobs says otherwise),
scores every run's trajectory (rbpf: the best particle's history, the trajectory of its final map; single_map:
the online estimate) with the package's evaluator (rbpf_slam.evaluate, as
`trajectory_eval`) against the bag's reference, and prints per seed and then median / worst:
  ATE RMS after a least-squares rigid fit, ATE RMS aligned at the first pose, RPE over pose pairs --travel
  metres of reference travel apart (mean translation [m] and rotation [deg]), wall time of the process [s],
  filter time [s], peak resident memory of the process [MB] (slam_bag's own VmHWM, what /usr/bin/time -v
  reports, where its timing.json has it) and, where slam_bag reports them, the map's storage [MB per particle
  per 1000 m2 of map].
The bag's odometry (the first run's odometry.tum) is scored alike. A peer's trajectory (`--peer NAME=FILE`:
one pose per scan of the bag, in order, as `t x y theta` or TUM lines) is scored by scan index; its time and
memory are whatever you give with --peer-time NAME=SECONDS,MB (printed beside, not measured here).

Every scan is processed unless --thresholds (then the configs' travel thresholds apply, as in the node).

Example:
  rosrun rbpf_slam grid_benchmark --bag intel.bag --seeds 0-9 \\
      --peer gmapping=gmapping_intel_all.txt --peer-time gmapping=83,66
Exit code 0; 1 with one line on stderr when an input is missing or malformed or a run fails.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

from rbpf_slam import atomic, evaluate as ev, paths


def parse_seeds(text):
    """'0-9' or '0,3,5' or '1' -> list of ints."""
    seeds = []
    for part in text.split(','):
        if '-' in part:
            lo, hi = part.split('-', 1)
            seeds.extend(range(int(lo), int(hi) + 1))
        else:
            seeds.append(int(part))
    if not seeds:
        raise ValueError('no seeds in %r' % text)
    return seeds


def find_slam_bag(explicit):
    """The runner: --slam-bag, else the package's built slam_bag (rbpf_slam.paths.program), else one on PATH."""
    if explicit:
        return explicit
    try:
        return paths.program('slam_bag')
    except ValueError:
        path = shutil.which('slam_bag')
        if path:
            return path
        raise ValueError('slam_bag: expected the built runner (scripts/bootstrap builds it), got none; give '
                         '--slam-bag')


def default_configs():
    """The shipped filter: config/grid_slam_advanced.yaml, then config/grid_slam.yaml on top."""
    return [paths.package_file('config', 'grid_slam_advanced.yaml'), paths.package_file('config', 'grid_slam.yaml')]


def run_seed(cmd):
    """Runs one slam_bag process; returns (wall seconds, peak RSS MB, stderr text, exit code)."""
    started = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.monotonic() - started
    err = proc.stderr.read().decode('utf-8', 'replace')
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status) if hasattr(os, 'waitstatus_to_exitcode') else status >> 8
    return wall, usage.ru_maxrss / 1024.0, err, proc.returncode


def median(values):
    v = sorted(x for x in values if x is not None)
    if not v:
        return None
    n = len(v)
    return v[n // 2] if n % 2 else 0.5 * (v[n // 2 - 1] + v[n // 2])


def worst(values):
    v = [x for x in values if x is not None]
    return max(v) if v else None


def fmt(v, spec):
    return ('%' + spec) % v if v is not None else '-'


COLUMNS = (('ATEfit m', 'ate', '.3f'), ('ATEfirst m', 'ate_first_pose', '.3f'),
           ('RPE m', 'rpe_translation_mean', '.4f'), ('RPE deg', 'rpe_rotation_mean_deg', '.3f'),
           ('time s', 'wall', '.1f'), ('filter s', 'filter', '.1f'), ('peak MB', 'rss', '.0f'),
           ('MB/p/1000m2', 'mb_per_particle_1000m2', '.3f'))


def row(name, values):
    return '%-22s' % name + ''.join(' %11s' % fmt(values.get(key), spec) for _, key, spec in COLUMNS)


def main(argv=None):
    return atomic.run_tool('grid_benchmark', _main, argv, errors=(ValueError,))


def _main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--bag', required=True, help='bag with scans, odometry TF and a reference path')
    p.add_argument('--seeds', default='0-9', help='seeds, e.g. 0-9 or 1,4 (default 0-9)')
    p.add_argument('--config', action='append', default=None, metavar='YAML',
                   help='filter configs, in order, later over earlier (default config/grid_slam_advanced.yaml '
                        'then config/grid_slam.yaml, the shipped filter; give both before your own)')
    p.add_argument('--particles', type=int, default=None, help='particles (default: the configs\')')
    p.add_argument('--thresholds', action='store_true',
                   help='apply the configs\' travel thresholds (default: every scan, slam_bag --every-scan)')
    p.add_argument('--truth', default='/ground_truth/odom', help='reference topic (nav_msgs/Odometry)')
    p.add_argument('--travel', type=float, default=1.0, help='RPE pair distance [m] (default 1)')
    p.add_argument('--tolerance', type=float, default=1e-3,
                   help='stamp pairing tolerance [s] (default 0.001: one reference pose per scan, as the '
                        'converters write it; simulated bags need about one reference period)')
    p.add_argument('--peer', action='append', default=[], metavar='NAME=FILE',
                   help='another system\'s trajectory of this bag, one pose per scan (paired by index)')
    p.add_argument('--peer-time', action='append', default=[], metavar='NAME=SECONDS,MB',
                   help='the time and peak memory the peer took, to print beside it')
    p.add_argument('--jobs', type=int, default=1, help='runs at once (default 1: timings are alone)')
    p.add_argument('--keep', metavar='DIR', help='keep the run folders here (default: a temporary folder)')
    p.add_argument('--slam-bag', help='the runner (default: the built slam_bag)')
    args = p.parse_args(argv)
    seeds = parse_seeds(args.seeds)
    configs = args.config or default_configs()
    for path in [args.bag] + configs:
        if not os.path.isfile(path):
            raise ValueError('%s: expected a file, got none' % path)
    peers = []
    for spec in args.peer:
        name, _, path = spec.partition('=')
        if not path or not os.path.isfile(path):
            raise ValueError('--peer %s: expected NAME=FILE with an existing file' % spec)
        peers.append((name, path))
    peer_time = {}
    for spec in args.peer_time:
        name, _, vals = spec.partition('=')
        try:
            seconds, mb = (float(v) for v in vals.split(','))
        except ValueError:
            raise ValueError('--peer-time %s: expected NAME=SECONDS,MB' % spec)
        peer_time[name] = (seconds, mb)
    slam_bag = find_slam_bag(args.slam_bag)
    ref_t, ref_xy, ref_yaw, _ = ev.read_bag_truth(args.bag, args.truth)
    ref = (ref_t, ref_xy, ref_yaw)

    out = args.keep or tempfile.mkdtemp(prefix='grid_benchmark_')
    os.makedirs(out, exist_ok=True)
    try:
        print('grid_benchmark: %s, seeds %s, %s, %s' % (args.bag, args.seeds, ' + '.join(
            os.path.basename(c) for c in configs), 'travel thresholds of the configs' if args.thresholds
            else 'every scan'))
        print('%-22s' % 'run' + ''.join(' %11s' % title for title, _, _ in COLUMNS))
        def command(seed):
            folder = os.path.join(out, 'seed%d' % seed)
            cmd = [slam_bag, '--filter', 'grid', '--bag', args.bag, '--seed', str(seed), '--out', folder, '--quiet']
            for c in configs:
                cmd += ['--config', c]
            if args.particles:
                cmd += ['--particles', str(args.particles)]
            if not args.thresholds:
                cmd.append('--every-scan')
            return folder, cmd

        def score(seed, outcome):
            folder, _ = command(seed)
            wall, rss, err, code = outcome
            if code != 0:
                raise ValueError('slam_bag seed %d failed (exit %d): %s' % (seed, code, err.strip()[-300:]))
            # rbpf: the best particle's history (the trajectory of the final map); single_map: its estimate.
            scored = os.path.join(folder, 'estimate_best_history.tum')
            if not os.path.isfile(scored):
                scored = os.path.join(folder, 'estimate.tum')
            e = ev.trajectory_errors(ev.read_trajectory(scored), ref, args.travel, args.tolerance)
            e.update(wall=wall, rss=rss, seed=seed, folder=folder, scored=os.path.basename(scored))
            timing = os.path.join(folder, 'timing.json')
            if os.path.isfile(timing):
                with open(timing) as f:
                    t = json.load(f)
                e['filter'] = t.get('seconds_filter')
                e['mb_per_particle_1000m2'] = t.get('mb_per_particle_per_1000m2')
                # The runner's own peak (VmHWM): the child's ru_maxrss also holds this process's pages, copied
                # at the fork before the exec.
                if t.get('peak_rss_mb'):
                    e['rss'] = t['peak_rss_mb']
            print(row('seed %d' % seed, e))
            sys.stdout.flush()
            return e

        if args.jobs <= 1:  # one at a time: the timings are the runs' own
            results = [score(seed, run_seed(command(seed)[1])) for seed in seeds]
        else:
            from concurrent.futures import ThreadPoolExecutor
            with ThreadPoolExecutor(args.jobs) as pool:
                outcomes = list(pool.map(lambda s: run_seed(command(s)[1]), seeds))
            results = [score(seed, o) for seed, o in zip(seeds, outcomes)]
        summary = {}
        for _, key, _ in COLUMNS:
            summary[key] = (median([r.get(key) for r in results]), worst([r.get(key) for r in results]))
        print(row('median', {k: v[0] for k, v in summary.items()}))
        print(row('worst', {k: v[1] for k, v in summary.items()}))
        odom = ev.trajectory_errors(ev.read_trajectory(os.path.join(results[0]['folder'], 'odometry.tum')), ref,
                                    args.travel, args.tolerance)
        print(row('odometry', odom))
        for name, path in peers:
            e = ev.trajectory_errors(ev.read_trajectory(path), ref, args.travel, args.tolerance, pair='index')
            if name in peer_time:
                e['wall'], e['rss'] = peer_time[name]
            print(row(name + ' (given)', e))
        print('scored: %s; poses paired per run: %s' % (
            ', '.join(sorted(set(r['scored'] for r in results))),
            ', '.join(str(r['poses']) for r in results[:3]) + (' ...' if len(results) > 3 else '')))
    finally:
        if not args.keep:
            shutil.rmtree(out, ignore_errors=True)
    return 0

