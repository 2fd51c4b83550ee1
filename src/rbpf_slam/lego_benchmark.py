"""FastSLAM on Claus Brenner's LEGO robot logs, through the shared bag runner and evaluator, over K seeds.

  rosrun rbpf_slam lego_benchmark [--data DIR] [--seeds 5] [--particles N] [--out results/lego]
      [--config-dir config/lego]

--data DIR is the directory holding the data sets (brenner_lego/, carmen/, ...); without it, the environment
variable RBPF_SLAM_DATA. The logs are read from DIR/brenner_lego (from DIR itself if it holds them).

Converts the logs once (lego_to_bag; the bag keeps the reference on ground_truth/* topics the runner never
reads), runs `slam_bag --scan /scan` with config/lego/{trunk_extraction,fastslam}.yaml for each seed,
scores each run with evaluate_bag_run (the scanner, 30 mm ahead of the robot centre by config/lego/robot.yaml,
after a least-squares rigid fit of the path onto the camera reference; the map moved by the same fit) and
prints the median and the worst seed beside the raw odometry, with the share of the reference inside the
estimate's stated 95 % region (a filter that states its uncertainty truly has it near 95 %). Writes OUT/summary.json and OUT/seedN/evaluation.png.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np

from rbpf_slam import atomic, lego, paths

PROG = 'lego_benchmark'


def run(cmd):
    proc = atomic.run_child(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    if proc.returncode != 0:
        raise RuntimeError('%s failed (%d):\n%s%s' % (' '.join(cmd), proc.returncode, proc.stdout, proc.stderr))
    return proc.stdout


def _coverage(row):
    """The share of reference positions inside the published estimate's 95 % region (after the fit); NaN when the
    run states no covariance."""
    c = (row.get('coverage_95') or {}).get('fitted')
    return np.nan if c is None else c


def report(logs, rows):
    """The printed lines and the summary (as OUT/summary.json holds it) of the runs' evaluation.json figures."""
    def col(get):
        return np.array([get(r) for r in rows], dtype=float)

    metrics = [
        ('path RMS [mm]', col(lambda r: 1000 * r['estimate']['path_rms']), col(lambda r: 1000 * r['odometry']['path_rms']), 'max'),
        ('final error [mm]', col(lambda r: 1000 * r['estimate']['final_error']), col(lambda r: 1000 * r['odometry']['final_error']), 'max'),
        ('landmark error [mm]', col(lambda r: 1000 * (r['map']['mean_error'] if r['map']['mean_error'] is not None else np.nan)), None, 'max'),
        ('true landmarks found', col(lambda r: r['map']['matched']), None, 'min'),
        ('duplicates', col(lambda r: r['map']['duplicates']), None, 'max'),
        ('spurious', col(lambda r: r['map']['spurious']), None, 'max'),
        ('truth in 95% region %', col(lambda r: 100 * _coverage(r)), None, 'min'),
        ('processing [ms]', col(lambda r: 1000 * r.get('seconds_processing', np.nan)), None, 'max'),
    ]
    lines = ['LEGO logs (%s), %d seeds, scanner point after a least-squares rigid fit onto the reference'
             % (logs, len(rows))]
    lines.append('%-22s %9s %9s %14s' % ('', 'median', 'worst', 'raw odometry'))
    summary = {'seeds': len(rows), 'runs': rows}
    for name, v, odo, worst in metrics:
        w = np.nanmax(v) if worst == 'max' else np.nanmin(v)
        lines.append('%-22s %9.1f %9.1f %14s' % (name, np.nanmedian(v), w, '%.1f' % np.median(odo) if odo is not None else ''))
        summary[name] = {'median': float(np.nanmedian(v)), 'worst': float(w),
                         'odometry': float(np.median(odo)) if odo is not None else None}
    return lines, summary


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr when a tool fails; 2 without a data directory."""
    return atomic.run_tool(PROG, _main, argv)


def _main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--data', metavar='DIR', default=os.environ.get('RBPF_SLAM_DATA') or None,
                   help='the directory holding the data sets (default: $RBPF_SLAM_DATA); logs in DIR/brenner_lego')
    p.add_argument('--seeds', type=int, default=5)
    p.add_argument('--particles', type=int, default=None, help='override the configuration (25)')
    p.add_argument('--out', default='results/lego')
    p.add_argument('--config-dir', default=None, help='default: the package\'s config/lego')
    args = p.parse_args(argv)
    args.config_dir = args.config_dir or paths.package_file('config', 'lego')
    if not args.data:
        sys.stderr.write('lego_benchmark: no data directory: give --data DIR or set RBPF_SLAM_DATA\n')
        return 2
    logs = os.path.join(args.data, 'brenner_lego')
    if not os.path.isdir(logs) and os.path.isfile(os.path.join(args.data, 'robot4_scan.txt')):
        logs = args.data  # DIR is the LEGO logs' folder itself
    try:
        os.makedirs(args.out, exist_ok=True)
        bag = os.path.join(args.out, 'lego.bag')
        run(['rosrun', 'rbpf_slam', 'lego_to_bag', logs, '-o', bag, '-q'])
        rows = []
        for seed in range(args.seeds):
            d = os.path.join(args.out, 'seed%d' % seed)
            cmd = ['rosrun', 'rbpf_slam', 'slam_bag', '--bag', bag, '--scan', '/scan', '--seed', str(seed),
                   '--extraction-config', os.path.join(args.config_dir, 'trunk_extraction.yaml'),
                   '--config', os.path.join(args.config_dir, 'fastslam.yaml'), '--out', d, '--quiet']
            if args.particles:
                cmd += ['--particles', str(args.particles)]
            run(cmd)
            run(['rosrun', 'rbpf_slam', 'evaluate_bag_run', '--bag', bag, '--run', d,
                 '--point-offset', repr(lego.SCANNER_X), '0', '--quiet'])
            with open(os.path.join(d, 'evaluation.json')) as f:
                rows.append(json.load(f))
    except (OSError, RuntimeError) as e:
        sys.stderr.write('lego_benchmark: %s\n' % e)
        return 1

    lines, summary = report(logs, rows)
    for line in lines:
        print(line)
    atomic.write_json(os.path.join(args.out, 'summary.json'), summary, indent=2)
    return 0
