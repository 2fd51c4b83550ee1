"""Plots one seed of a fastslam_benchmark --out DIR run: paths (estimate, raw odometry, truth, all
anchored at the start) with the map against the true trees, and the position error over time.
With --report it writes the run's one-page report instead: DIR/report.md (figures over all seeds from
DIR/summary.json, RPE computed here from the TUM files), DIR/report.json and three PNGs (paths, map,
error over time) of the seed with the median final error.

  rosrun rbpf_slam plot_forest_run DIR [--seed N] [--out FILE.png]
  rosrun rbpf_slam plot_forest_run DIR --report [--seed N]
"""
import argparse
import csv
import json
import math
import os
import sys

import numpy as np

from rbpf_slam import atomic, evaluate as ev

# The figures of the paper this package reproduces, on its straight drive (for contrast in the report).
PAPER = {'final_error_m': 2.39, 'tree_to_feature_m': 0.81, 'duplicates': 5, 'spurious': 1, 'rate_hz': 1.0}
RPE_DELTA = 1.0  # [m] of true travel between the two poses of an RPE pair


def read_tum_poses(path):
    """TUM file -> (t, N x 3 array of x, y, yaw)."""
    t, xy, yaw = ev.read_tum(path)
    return t, np.column_stack([xy, yaw])


def read_tum(path):
    t, poses = read_tum_poses(path)
    return t, poses[:, :2]


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def relative_pose_error(estimate, truth, delta=RPE_DELTA):
    """The shared evaluator's RPE (rbpf_slam.evaluate.relative_pose_error)."""
    return ev.relative_pose_error(estimate, truth, delta)


def position_errors(estimate, truth):
    return np.hypot(*(estimate[:, :2] - truth[:, :2]).T)


def _seeds(directory):
    return sorted(int(f[4:-13]) for f in os.listdir(directory) if f.startswith('seed') and f.endswith('_estimate.tum'))


def median_seed(summary, seeds):
    """The seed whose final error is the median one (the lower middle for an even count)."""
    if not summary or 'final_error_m' not in summary:
        return seeds[0]
    values = summary['final_error_m']['values']
    first = summary.get('first_seed', seeds[0])
    order = sorted(range(len(values)), key=lambda k: values[k])
    seed = first + order[(len(order) - 1) // 2]
    return seed if seed in seeds else seeds[0]


def _fmt(v, unit='', scale=1.0, digits=3):
    """digits None: as short as exact (counts)."""
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return 'n/a'
    return (('%g' % (v * scale)) if digits is None else ('%.*f' % (digits, v * scale))) + unit


def write_report(directory, seed=None):
    """Writes report.md, report.json and report_{paths,map,error}.png into DIR; returns report.md's path."""
    seeds = _seeds(directory)
    if not seeds:
        raise ValueError('%s: no seed*_estimate.tum' % directory)
    summary_path = os.path.join(directory, 'summary.json')
    summary = None
    if os.path.exists(summary_path):
        with open(summary_path) as f:
            summary = json.load(f)
    shown = seed if seed is not None else median_seed(summary, seeds)
    if shown not in seeds:
        raise ValueError('%s: no run of seed %d (seeds: %s)' % (directory, shown, seeds))

    per_seed = {}
    for s in seeds:
        base = os.path.join(directory, 'seed%d' % s)
        _, est = read_tum_poses(base + '_estimate.tum')
        _, odo = read_tum_poses(base + '_odometry.tum')
        _, tru = read_tum_poses(base + '_truth.tum')
        rpe_t, rpe_r, pairs = relative_pose_error(est, tru)
        rpe_dt, rpe_dr, _ = relative_pose_error(odo, tru)
        per_seed[s] = {'rpe_m': rpe_t, 'rpe_deg': rpe_r, 'rpe_pairs': pairs,
                       'rpe_dead_reckoning_m': rpe_dt, 'rpe_dead_reckoning_deg': rpe_dr,
                       'final_error_m': float(position_errors(est, tru)[-1]),
                       'final_error_dead_reckoning_m': float(position_errors(odo, tru)[-1])}

    def stats(key, larger_is_worse=True):
        v = [per_seed[s][key] for s in seeds if not math.isnan(per_seed[s][key])]
        if not v:
            return {'median': float('nan'), 'worst': float('nan'), 'values': []}
        return {'median': float(np.median(v)), 'worst': float(max(v) if larger_is_worse else min(v)), 'values': v}

    report = dict(summary or {})
    report['rpe_delta_m'] = RPE_DELTA
    report['rpe_m'] = stats('rpe_m')
    report['rpe_deg'] = stats('rpe_deg')
    report['rpe_dead_reckoning_m'] = stats('rpe_dead_reckoning_m', False)
    report['rpe_dead_reckoning_deg'] = stats('rpe_dead_reckoning_deg', False)
    report['per_seed'] = {str(s): per_seed[s] for s in seeds}
    report['shown_seed'] = shown
    report['paper'] = PAPER
    if summary is None:  # a folder without summary.json: the final errors from the TUM files
        report['final_error_m'] = stats('final_error_m')
        report['final_error_dead_reckoning_m'] = stats('final_error_dead_reckoning_m', False)
    figures = _plot_report(directory, shown)
    report['figures'] = figures
    atomic.write_json(os.path.join(directory, 'report.json'), report, indent=1, sort_keys=True)

    def row(name, key, unit='', scale=1.0, digits=3, dr_key=None, paper=None):
        m = report.get(key)
        if not m:
            return None
        dr = report.get(dr_key) if dr_key else None
        return '| %s | %s | %s | %s | %s |' % (
            name, _fmt(m['median'], unit, scale, digits), _fmt(m['worst'], unit, scale, digits),
            (_fmt(dr['median'], unit, scale, digits) + ' (least ' + _fmt(dr['worst'], unit, scale, digits) + ')')
            if dr else '', '' if paper is None else paper)

    n = len(seeds)
    title = 'FastSLAM forest run'
    if summary:
        title += ': %s, %s drive, %d particles, %s extraction' % (
            os.path.basename(summary.get('world', '?')), summary.get('drive', '?'), summary.get('particles', 0),
            summary.get('method', '?'))
    lines = ['# ' + title, '']
    if summary:
        lines += ['%d seeds (%d..%d); failed runs (final error > 1 m): **%d of %d**. Reproduce with:' % (
            n, summary.get('first_seed', seeds[0]), summary.get('first_seed', seeds[0]) + n - 1,
            summary.get('failed', 0), n), '',
            '```', 'rosrun rbpf_slam fastslam_benchmark --world %s --drive %s --particles %d --method %s '
            '--first-seed %d --seeds %d --out DIR' % (summary.get('world'), summary.get('drive'),
                                                   summary.get('particles', 0), summary.get('method'),
                                                   summary.get('first_seed', seeds[0]), n),
            'rosrun rbpf_slam plot_forest_run DIR --report', '```', '']
    lines += ['Positions of `base_link` in the start frame (the map frame), no alignment: the start pose is known. '
              'Dead reckoning is the same run\'s raw wheel odometry; its "least" is the smallest drift over the '
              'seeds. RPE over pose pairs %g m of true travel apart.' % RPE_DELTA, '',
              '| metric | median | worst | dead reckoning, median | the paper |', '|---|---|---|---|---|']
    rows = [row('final position error', 'final_error_m', ' m', dr_key='final_error_dead_reckoning_m',
                paper='%.2f m' % PAPER['final_error_m']),
            row('ATE (RMS)', 'ate_m', ' m', dr_key='ate_dead_reckoning_m'),
            row('RPE translation', 'rpe_m', ' m', dr_key='rpe_dead_reckoning_m'),
            row('RPE rotation', 'rpe_deg', ' deg', digits=2, dr_key='rpe_dead_reckoning_deg'),
            row('tree to feature', 'tree_to_feature_m', ' m', paper='%.2f m' % PAPER['tree_to_feature_m']),
            row('fused radius error (RMS)', 'radius_rms_m', ' cm', scale=100.0, digits=2),
            row('recall', 'recall', ' %', scale=100.0, digits=1),
            row('duplicates', 'duplicates', '', digits=None, paper=str(PAPER['duplicates'])),
            row('spurious', 'spurious', '', digits=None, paper=str(PAPER['spurious'])),
            row('rate (extraction + filter)', 'rate_hz', ' Hz', digits=0, paper='~%g Hz' % PAPER['rate_hz'])]
    lines += [r for r in rows if r]
    lines += ['', 'Recall and rate: "worst" is the lowest. Counting: optimal assignment with a 0.5 m gate; '
              'duplicates within 1 m of a matched tree; spurious = matched to nothing; provisional features count.',
              '', '## Seed %d (median final error)' % shown if seed is None else '## Seed %d' % shown, '',
              '![paths](%s)' % figures[0], '', '![map](%s) ![error](%s)' % (figures[1], figures[2]), '']
    out = os.path.join(directory, 'report.md')
    atomic.write_text(out, '\n'.join(lines))
    return out


def _plot_report(directory, seed):
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    base = os.path.join(directory, 'seed%d' % seed)
    t, est = read_tum_poses(base + '_estimate.tum')
    _, odo = read_tum_poses(base + '_odometry.tum')
    _, tru = read_tum_poses(base + '_truth.tum')
    trees = read_csv(base + '_trees.csv')
    feats = ev.read_landmarks_csv(base + '_map.csv')
    names = ['report_paths.png', 'report_map.png', 'report_error.png']

    fig, ax = plt.subplots(figsize=(10, 5))
    for tr in trees:
        ax.add_patch(plt.Circle((float(tr['x']), float(tr['y'])), max(float(tr['radius']), 0.05), color='saddlebrown',
                                alpha=0.6 if tr['seen'] == '1' else 0.2))
    ax.plot(tru[:, 0], tru[:, 1], 'g-', lw=6, alpha=0.45, label='truth (wide: the estimate runs on it)')
    ax.plot(odo[:, 0], odo[:, 1], 'r--', label='raw odometry')
    ax.plot(est[:, 0], est[:, 1], 'b-', lw=1.2, label='FastSLAM (best particle)')
    ax.plot(tru[0, 0], tru[0, 1], 'ko', ms=6, label='start (all anchored here)')
    ax.set_aspect('equal')
    ax.set_xlabel('x [m] (start frame)')
    ax.set_ylabel('y [m]')
    ax.set_title('seed %d: paths (brown: true trees; faint: never in the 1-12 m scope)' % seed, fontsize=10)
    ax.legend(loc='upper left', bbox_to_anchor=(1.01, 1.0), fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    atomic.save_figure(fig, os.path.join(directory, names[0]), dpi=90)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 5))
    for tr in trees:
        ax.add_patch(plt.Circle((float(tr['x']), float(tr['y'])), float(tr['radius']), fill=False, color='saddlebrown',
                                lw=2, alpha=1.0 if tr['seen'] == '1' else 0.3))
    for x, y, radius, prov in zip(feats['x'], feats['y'], feats['radius'], feats['provisional']):
        ax.add_patch(plt.Circle((x, y), max(radius, 0.02), fill=False, color='orange' if prov else 'blue',
                                lw=1, ls='--'))
        ax.plot(x, y, '+', color='orange' if prov else 'blue', ms=6)
    ax.plot([], [], 'o', mfc='none', color='saddlebrown', label='true trunk (radius)')
    ax.plot([], [], '+', color='blue', label='landmark (fused radius, dashed)')
    ax.plot([], [], '+', color='orange', label='provisional')
    ax.set_aspect('equal')
    ax.autoscale_view()
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_title('seed %d: map against the truth' % seed, fontsize=10)
    ax.legend(loc='upper center', bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=7)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    atomic.save_figure(fig, os.path.join(directory, names[1]), dpi=90)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(5.5, 5))
    ax.plot(t - t[0], position_errors(est, tru), 'b-', label='FastSLAM')
    ax.plot(t - t[0], position_errors(odo, tru), 'r--', label='raw odometry')
    ax.set_xlabel('time [s]')
    ax.set_ylabel('position error [m]')
    ax.set_title('seed %d: error over time' % seed, fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    atomic.save_figure(fig, os.path.join(directory, names[2]), dpi=90)
    plt.close(fig)
    return names


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr for a missing or malformed input."""
    return atomic.run_tool('plot_forest_run', _main, argv, errors=(ValueError, KeyError))


def _main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument('dir', help='output folder of fastslam_benchmark --out')
    parser.add_argument('--seed', type=int, default=None, help='seed to plot (default: the first found)')
    parser.add_argument('--out', default=None, help='PNG to write (default: DIR/seedN.png)')
    parser.add_argument('--report', action='store_true',
                        help='write DIR/report.md, report.json and report_*.png (seed: the median final error)')
    args = parser.parse_args(argv)
    seeds = _seeds(args.dir) if os.path.isdir(args.dir) else []
    if not seeds:
        sys.stderr.write('plot_forest_run: no seed*_estimate.tum in %s\n' % args.dir)
        return 1
    if args.report:
        print('wrote %s' % write_report(args.dir, args.seed))
        return 0
    seed = args.seed if args.seed is not None else seeds[0]
    base = os.path.join(args.dir, 'seed%d' % seed)
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    t, est = read_tum(base + '_estimate.tum')
    _, odo = read_tum(base + '_odometry.tum')
    _, tru = read_tum(base + '_truth.tum')
    trees = read_csv(base + '_trees.csv')
    feats = ev.read_landmarks_csv(base + '_map.csv')

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(13, 5.5), gridspec_kw={'width_ratios': [2, 1]})
    for tr in trees:
        ax.add_patch(plt.Circle((float(tr['x']), float(tr['y'])), max(float(tr['radius']), 0.05),
                                color='green', alpha=0.5 if tr['seen'] == '1' else 0.15))
    ax.plot(tru[:, 0], tru[:, 1], 'g-', label='truth')
    ax.plot(odo[:, 0], odo[:, 1], 'r--', label='raw odometry')
    ax.plot(est[:, 0], est[:, 1], 'b-', label='FastSLAM (best particle)')
    prov = feats['provisional']
    ax.plot(feats['x'][~prov], feats['y'][~prov], 'b+', ms=10, label='landmarks')
    if prov.any():
        ax.plot(feats['x'][prov], feats['y'][prov], 'c+', ms=8, label='provisional')
    smoothed = None
    if os.path.exists(base + '_estimate_smoothed.tum'):
        # Loop closure: the run smoothed at its end (path and map).
        ts, sm = read_tum(base + '_estimate_smoothed.tum')
        sfeats = ev.read_landmarks_csv(base + '_map_smoothed.csv')
        ax.plot(sm[:, 0], sm[:, 1], 'm-', lw=1.2, label='smoothed (loop closure)')
        ax.plot(sfeats['x'], sfeats['y'], 'mx', ms=7, label='smoothed map')
        idx = np.clip(np.searchsorted(t, ts), 0, len(t) - 1)
        smoothed = (ts, np.hypot(*(sm - tru[idx]).T))
    ax.set_aspect('equal')
    ax.set_xlabel('x [m] (start frame)')
    ax.set_ylabel('y [m]')
    ax.set_title('seed %d: paths and map (green discs: true trees; faint: never in scope)' % seed)
    ax.legend(loc='best', fontsize=8)
    ax.grid(True, alpha=0.3)

    ax2.plot(t, np.hypot(*(est - tru).T), 'b-', label='FastSLAM')
    ax2.plot(t, np.hypot(*(odo - tru).T), 'r--', label='raw odometry')
    if smoothed is not None:
        ax2.plot(smoothed[0], smoothed[1], 'm-', label='smoothed')
    ax2.set_xlabel('time [s]')
    ax2.set_ylabel('position error [m]')
    ax2.set_title('error over time')
    ax2.legend(fontsize=8)
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    out = args.out or base + '.png'
    atomic.save_figure(fig, out, dpi=90)
    print('wrote %s' % out)
    return 0
