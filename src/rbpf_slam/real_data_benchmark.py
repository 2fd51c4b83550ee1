"""FastSLAM on two real data sets, Victoria Park and UTIAS MR.CLAM, over K seeds, each figure beside the same
run's dead reckoning.

  rosrun rbpf_slam real_data_benchmark [--data DIR] [--seeds 5] [--first-seed 0] [--out results/real_data]
      [--only vp_detections,vp_laser,mrclam,mrclam_known_ids] [--robots 1,2,3,4,5] [--keep-bags]

--data DIR is the directory holding the data sets; without it, the environment variable RBPF_SLAM_DATA. Read
from DIR/victoria_park (victoria_park_ascii.zip, published_measurements.dat.gz) and DIR/mrclam (RobotN_*.dat.gz,
Landmark_Groundtruth.dat.gz, Barcodes.dat.gz).

1. Converts the logs once into OUT/bags/ (victoria_park_to_bag --detections; mrclam_to_bag --robot N for each
   robot); a bag newer than its inputs is reused. The bags are removed at the end unless --keep-bags.
2. Runs slam_bag once per seed (and robot) with the inputs and configuration of the table DATA_SETS below:
     vp_detections     the published tree detections (/landmarks), config/fastslam_advanced.yaml +
                       config/fastslam.yaml + odometry/car.yaml
     vp_laser          the raw 2D laser (/scan) through the trunk extraction, the same configuration +
                       scanner_2d.yaml (provisional landmarks weigh no particle: a planar scan's clutter)
     mrclam            the barcode readings (/landmarks), unknown association, config/fastslam_advanced.yaml +
                       config/fastslam.yaml + odometry/indoor_commanded.yaml
     mrclam_known_ids  the same with an overlay OUT/known_ids.yaml holding only use_known_ids: true (the barcode
                       names the landmark: known association is a property of the data, not a tuning)
   Each call is timed (wall clock). Outputs in OUT/<set>/seedS (MR.CLAM: OUT/<set>/robotN/seedS).
3. Scores each run with evaluate_bag_run (RUNDIR/evaluation.json and evaluation.png).
4. Prints a table per data set: median and worst over the seeds (worst = the largest error, the smallest recall
   or coverage) of the ATE after a rigid fit (MR.CLAM also without a fit: its reference is in the start frame)
   beside the dead reckoning's, for MR.CLAM the landmarks matched within 0.5 m (of 15), duplicates and spurious
   landmarks, the share of reference poses inside the particle cloud's 95 % region (without a fit on MR.CLAM,
   after the fit on Victoria Park, whose GPS frame is unknown), the share of updates where the filter's health
   monitor warned, and the wall time per run. MR.CLAM pools all robots and seeds, and adds a line per robot
   (median over the seeds). Each table ends with the runs that ended well and badly (ATE after the fit within
   5 m on Victoria Park, 0.3 m on MR.CLAM) and how often the health monitor warned in each group.
5. Copies the evaluation.png of the best and the worst Victoria Park run of each set to OUT/<set>_best.png and
   OUT/<set>_worst.png, and writes OUT/summary.json (every run's figures and the tables).

Progress goes to stderr, the tables to stdout. Exit code 0; 2 for a bad command line or missing data; 1 when a
tool failed (the other runs are still scored and summarized).
"""
import argparse
import errno
import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np

from rbpf_slam import atomic, paths

# The data sets: one entry each. 'configs' are the --config files in order (later ones override earlier ones),
# relative to the package's folder; 'extraction_config' the --extraction-config (None: the built-in defaults,
# which config/trunk_extraction.yaml states value for value); 'known_ids' adds the overlay use_known_ids: true.
# 'good_ate' [m]: a run whose ATE after the rigid fit is at most this "ended well". 'coverage': which 95 %
# coverage the table shows ('fitted' where the reference frame is unknown, 'no_fit' where it is the start frame).
DATA_SETS = {
    'vp_detections': {
        'title': 'Victoria Park, the published tree detections',
        'data': 'victoria_park', 'bag': 'victoria_park',
        'input': ['--landmarks', '/landmarks'],
        'configs': ['config/fastslam_advanced.yaml', 'config/fastslam.yaml', 'config/odometry/car.yaml'],
        'extraction_config': None, 'known_ids': False,
        'good_ate': 5.0, 'coverage': 'fitted', 'gate': None,
    },
    'vp_laser': {
        'title': 'Victoria Park, trunks extracted from the raw 2D laser',
        'data': 'victoria_park', 'bag': 'victoria_park',
        'input': ['--scan', '/scan'],
        'configs': ['config/fastslam_advanced.yaml', 'config/fastslam.yaml', 'config/odometry/car.yaml',
                    'config/scanner_2d.yaml'],
        'extraction_config': None, 'known_ids': False,
        'good_ate': 5.0, 'coverage': 'fitted', 'gate': None,
    },
    'mrclam': {
        'title': 'MR.CLAM Dataset 1, barcode readings, unknown association',
        'data': 'mrclam', 'bag': 'mrclam',
        'input': ['--landmarks', '/landmarks'],
        'configs': ['config/fastslam_advanced.yaml', 'config/fastslam.yaml', 'config/odometry/indoor_commanded.yaml'],
        'extraction_config': None, 'known_ids': False,
        'good_ate': 0.3, 'coverage': 'no_fit', 'gate': 0.5,
    },
    'mrclam_known_ids': {
        'title': 'MR.CLAM Dataset 1, barcode readings, known association (the barcode)',
        'data': 'mrclam', 'bag': 'mrclam',
        'input': ['--landmarks', '/landmarks'],
        'configs': ['config/fastslam_advanced.yaml', 'config/fastslam.yaml', 'config/odometry/indoor_commanded.yaml'],
        'extraction_config': None, 'known_ids': True,
        'good_ate': 0.3, 'coverage': 'no_fit', 'gate': 0.5,
    },
}
MRCLAM_ROBOTS = (1, 2, 3, 4, 5)
KNOWN_IDS_OVERLAY = 'use_known_ids: true\n'

PROG = 'real_data_benchmark'
RETRY_WAIT_S = 30  # a program being rebuilt ("text file busy", or gone for a moment): wait, then try again
RETRIES = 10  # up to 5 min: a rebuild of the package


class DataError(Exception):
    """Missing or incomplete data: exit code 2."""


def log(text):
    sys.stderr.write('%s: %s\n' % (PROG, text))
    sys.stderr.flush()


# --- Figures ------------------------------------------------------------------------------------------------

def run_figures(evaluation, wall_s):
    """The figures of one run from its evaluation.json (keys an older evaluation lacks are None)."""
    ev = evaluation or {}
    est, odo = ev.get('estimate') or {}, ev.get('odometry') or {}
    sm = ev.get('smoothed') or {}
    sm_est, sm_nf = sm.get('estimate') or {}, sm.get('no_fit') or {}
    nf = ev.get('no_fit') or {}
    m, m_nf = ev.get('map') or {}, nf.get('map') or {}
    cov = ev.get('coverage_95') or {}
    hw = ev.get('health_warned_updates')
    warned, updates = (hw[0], hw[1]) if hw and len(hw) == 2 else (None, None)
    return {
        'ate': est.get('path_rms'), 'ate_no_fit': (nf.get('estimate') or {}).get('path_rms'),
        'ate_smoothed': sm_est.get('path_rms'), 'ate_smoothed_no_fit': (sm_nf.get('estimate') or {}).get('path_rms'),
        'dr_ate': odo.get('path_rms'), 'dr_ate_no_fit': (nf.get('odometry') or {}).get('path_rms'),
        'final_error': est.get('final_error'), 'dr_final_error': odo.get('final_error'),
        'landmarks': m.get('trees'), 'features': m.get('features'),
        'matched': m.get('matched'), 'duplicates': m.get('duplicates'), 'spurious': m.get('spurious'),
        'matched_no_fit': m_nf.get('matched'),
        'coverage_fitted': cov.get('fitted'), 'coverage_no_fit': cov.get('no_fit'),
        'coverage_compared': cov.get('compared'),
        'health_warned': warned, 'health_updates': updates,
        'health_share': (float(warned) / updates) if updates else None,
        'processing_s': ev.get('seconds_processing'), 'wall_s': wall_s,
    }


def median_worst(values, worst='max'):
    """{'median', 'worst', 'n'} over the values that are numbers (None and NaN left out; None when none is);
    worst is the largest value ('max', errors) or the smallest ('min', recall and coverage)."""
    v = np.array([x for x in values if x is not None], dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return {'median': None, 'worst': None, 'n': 0}
    return {'median': float(np.median(v)), 'worst': float(v.max() if worst == 'max' else v.min()), 'n': int(v.size)}


LABEL_WIDTH = 36
# (label, key, dead-reckoning key, worst, scale, format, MR.CLAM only)
ROWS = [
    ('ATE, rigid fit [m]', 'ate', 'dr_ate', 'max', 1.0, '%.2f', False),
    ('ATE, no fit [m]', 'ate_no_fit', 'dr_ate_no_fit', 'max', 1.0, '%.2f', True),
    ('smoothed: ATE, rigid fit [m]', 'ate_smoothed', 'dr_ate', 'max', 1.0, '%.2f', False),
    ('smoothed: ATE, no fit [m]', 'ate_smoothed_no_fit', 'dr_ate_no_fit', 'max', 1.0, '%.2f', True),
    ('landmarks matched (of %s)', 'matched', None, 'min', 1.0, '%.0f', True),
    ('duplicates', 'duplicates', None, 'max', 1.0, '%.0f', True),
    ('spurious', 'spurious', None, 'max', 1.0, '%.0f', True),
    ('truth in the 95 %% region, %s [%%]', 'coverage', None, 'min', 100.0, '%.1f', False),
    ('health warned [% of updates]', 'health_share', None, 'max', 100.0, '%.1f', False),
    ('wall time per run [s]', 'wall_s', None, 'max', 1.0, '%.1f', False),
]


def is_mrclam(spec):
    return spec['data'] == 'mrclam'


def _coverage(run, spec):
    return run.get('coverage_' + spec['coverage'])


def set_table(runs, spec):
    """The table of one data set from its runs' figures (failed runs left out): {key: {label, median, worst, n,
    dead_reckoning: {median, worst, n} or None}} in the order of ROWS, plus the groups of ended_well()."""
    ok = [r for r in runs if not r.get('failed')]
    table = []
    for label, key, dr_key, worst, scale, fmt, mrclam_only in ROWS:
        if mrclam_only and not is_mrclam(spec):
            continue
        get = (lambda r: _coverage(r, spec)) if key == 'coverage' else (lambda r, k=key: r.get(k))
        if '%s' in label:
            if key == 'matched':
                counts = sorted(set(r['landmarks'] for r in ok if r.get('landmarks') is not None))
                label = label % ('/'.join(str(c) for c in counts) or '-')
            else:
                label = label % ('no fit' if spec['coverage'] == 'no_fit' else 'fitted')
        label = label.replace('%%', '%')
        values = [get(r) for r in ok]
        row = {'key': key, 'label': label, 'worst_is': worst, 'scale': scale, 'format': fmt}
        row.update(median_worst(values, worst))
        row['dead_reckoning'] = median_worst([r.get(dr_key) for r in ok], worst) if dr_key else None
        table.append(row)
    return {'rows': table, 'groups': ended_well(ok, spec['good_ate'])}


def ended_well(runs, good_ate):
    """The runs that ended well (ATE after the fit <= good_ate) and badly, with the share of updates where the
    health monitor warned in each group (all its updates together) and the median over its runs."""
    groups = {}
    for name, member in (('well', lambda a: a <= good_ate), ('badly', lambda a: a > good_ate)):
        g = [r for r in runs if r.get('ate') is not None and member(r['ate'])]
        warned = [r for r in g if r.get('health_updates')]
        total = sum(r['health_updates'] for r in warned)
        groups[name] = {
            'runs': len(g),
            'health_warned_pooled': (float(sum(r['health_warned'] for r in warned)) / total) if total else None,
            'health_warned_median': median_worst([r.get('health_share') for r in g])['median'],
        }
    groups['threshold_ate'] = good_ate
    groups['unscored'] = sum(1 for r in runs if r.get('ate') is None)
    return groups


def _cell(value, row):
    return '-' if value is None else row['format'] % (row['scale'] * value)


def _pct(share):
    return '-' if share is None else '%.0f %%' % (100 * share)


def format_table(name, spec, table, runs, seeds_text):
    """The printed table of one data set (a string)."""
    failed = sum(1 for r in runs if r.get('failed'))
    n = len(runs) - failed
    head = '%s: %s; %d run%s (%s)' % (name, spec['title'], n, '' if n == 1 else 's', seeds_text)
    if failed:
        head += ', %d FAILED' % failed
    row_format = '%-' + str(LABEL_WIDTH) + 's %9s %9s   %9s %9s'
    lines = [head, (('%-' + str(LABEL_WIDTH) + 's %19s   %19s') % ('', 'SLAM       ', 'dead reckoning  ')).rstrip(),
             row_format % ('', 'median', 'worst', 'median', 'worst')]
    for row in table['rows']:
        if row['key'] in ('matched', 'duplicates', 'spurious') and row['n'] == 0:
            continue  # no true landmarks to score the map on
        dr = row['dead_reckoning']
        lines.append((row_format % (row['label'], _cell(row['median'], row), _cell(row['worst'], row),
                                    _cell(dr['median'], row) if dr else '', _cell(dr['worst'], row) if dr else '')
                      ).rstrip())
    g = table['groups']
    for name, label in (('well', 'ended well (ATE fit <= %g m):' % g['threshold_ate']),
                        ('badly', 'ended badly:')):
        lines.append('%-*s %3d run(s), health warned in %s of their updates (median run %s)'
                     % (LABEL_WIDTH, label, g[name]['runs'], _pct(g[name]['health_warned_pooled']),
                        _pct(g[name]['health_warned_median'])))
    return '\n'.join(lines)


def per_robot(runs, spec):
    """MR.CLAM: one entry per robot, medians over its seeds."""
    out = {}
    for robot in sorted(set(r['robot'] for r in runs if r.get('robot') is not None)):
        mine = [r for r in runs if r.get('robot') == robot and not r.get('failed')]
        med = {k: median_worst([r.get(k) for r in mine])['median']
               for k in ('ate', 'ate_no_fit', 'dr_ate', 'dr_ate_no_fit', 'matched', 'health_share', 'wall_s')}
        med['coverage'] = median_worst([_coverage(r, spec) for r in mine])['median']
        med['runs'] = len(mine)
        med['ended_well'] = sum(1 for r in mine if r.get('ate') is not None and r['ate'] <= spec['good_ate'])
        out[robot] = med
    return out


def format_per_robot(robots):
    """The lines per robot of MR.CLAM (a string)."""
    def f(v, fmt='%.2f', scale=1.0):
        return '-' if v is None else fmt % (scale * v)
    row = '%-16s %8s %8s %8s %8s %8s %9s %9s %11s'
    lines = ['per robot, median over the seeds',
             row % ('', 'ATE fit', 'no fit', 'DR fit', 'no fit', 'matched', 'cover. %', 'health %', 'ended well')]
    for robot, m in sorted(robots.items()):
        lines.append((row % ('  robot %d' % robot, f(m['ate']), f(m['ate_no_fit']), f(m['dr_ate']),
                             f(m['dr_ate_no_fit']), f(m['matched'], '%.0f'), f(m['coverage'], '%.1f', 100),
                             f(m['health_share'], '%.1f', 100), '%d of %d' % (m['ended_well'], m['runs']))).rstrip())
    return '\n'.join(lines)


# --- Command line and data ----------------------------------------------------------------------------------

def parse_list(text, allowed, what):
    items = [x.strip() for x in text.split(',') if x.strip()]
    bad = [x for x in items if x not in allowed]
    if bad or not items:
        raise argparse.ArgumentTypeError('unknown %s %s (known: %s)' % (what, ', '.join(bad) or "''",
                                                                         ', '.join(str(a) for a in allowed)))
    return [x for x in allowed if x in items]  # in the table's order, each once


def parse_args(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--data', metavar='DIR', default=os.environ.get(paths.DATA_ENV) or None,
                   help='the directory holding victoria_park/ and mrclam/ (default: $%s)' % paths.DATA_ENV)
    p.add_argument('--seeds', type=int, default=5, help='runs per data set (and robot) (default 5)')
    p.add_argument('--first-seed', type=int, default=0, help='seeds first-seed .. first-seed + seeds - 1 (default 0)')
    p.add_argument('--out', default=os.path.join('results', 'real_data'), help='default: results/real_data')
    p.add_argument('--only', type=lambda s: parse_list(s, list(DATA_SETS), 'data set'), default=list(DATA_SETS),
                   help='comma-separated data sets (default: all): %s' % ','.join(DATA_SETS))
    p.add_argument('--robots', type=lambda s: [int(x) for x in parse_list(s, [str(r) for r in MRCLAM_ROBOTS],
                                                                          'robot')],
                   default=list(MRCLAM_ROBOTS), help='MR.CLAM robots (default 1,2,3,4,5)')
    p.add_argument('--keep-bags', action='store_true', help='keep OUT/bags/ (reused by the next run) ')
    args = p.parse_args(argv)
    if args.seeds < 1:
        p.error('--seeds must be at least 1')
    if args.first_seed < 0:
        p.error('--first-seed must not be negative')
    return args


def _find(folder, *names):
    """The first of names (each also with .gz) in folder, else None."""
    for name in names:
        for candidate in (name, name + '.gz'):
            path = os.path.join(folder, candidate)
            if os.path.isfile(path):
                return path
    return None


def data_inputs(data, sets, robots):
    """{bag name: (converter command without -o, [input files][, file name of the bag when not the bag name])} for
    the selected sets; DataError naming what is missing (the published detections only when vp_detections runs)."""
    if not data:
        raise DataError('no data directory: give --data DIR or set %s' % paths.DATA_ENV)
    if not os.path.isdir(data):
        raise DataError('%s: no such data directory' % data)
    bags = {}
    vp_sets = [s for s in sets if DATA_SETS[s]['data'] == 'victoria_park']
    if vp_sets:
        vp = os.path.join(data, 'victoria_park')
        log_files = [_find(vp, 'victoria_park_ascii.zip')]
        if log_files[0] is None:  # the files extracted from it
            log_files = [_find(vp, n) for n in ('LASER.txt', 'DRS.txt', 'GPS.txt')]
        detections = _find(vp, 'published_measurements.dat')
        missing = [] if all(log_files) else ['victoria_park_ascii.zip (or LASER.txt, DRS.txt, GPS.txt)']
        if detections is None and 'vp_detections' in vp_sets:
            missing.append('published_measurements.dat.gz')
        if missing:
            raise DataError('%s: missing %s (needed by %s)' % (vp, ', '.join(missing), ', '.join(vp_sets)))
        if detections is not None:  # one bag for both sets
            bags['victoria_park'] = (['victoria_park_to_bag', vp, '--detections', '-q'], log_files + [detections])
        else:  # the laser alone: a bag of its own name, never taken for one that holds the detections
            bags['victoria_park'] = (['victoria_park_to_bag', vp, '-q'], log_files, 'victoria_park_laser_only')
    mr_sets = [s for s in sets if DATA_SETS[s]['data'] == 'mrclam']
    if mr_sets:
        mr = os.path.join(data, 'mrclam')
        common = [_find(mr, 'Landmark_Groundtruth.dat'), _find(mr, 'Barcodes.dat')]
        missing = [n for n, f in zip(('Landmark_Groundtruth.dat.gz', 'Barcodes.dat.gz'), common) if f is None]
        for robot in robots:
            files = [_find(mr, 'Robot%d_%s.dat' % (robot, k)) for k in ('Odometry', 'Measurement', 'Groundtruth')]
            missing += ['Robot%d_%s.dat.gz' % (robot, k) for k, f in zip(('Odometry', 'Measurement', 'Groundtruth'),
                                                                         files) if f is None]
            bags['mrclam%d' % robot] = (['mrclam_to_bag', mr, '--robot', str(robot), '-q'], files + common)
        if missing:
            raise DataError('%s: missing %s (needed by %s)' % (mr, ', '.join(missing), ', '.join(mr_sets)))
    return bags


# --- Running ------------------------------------------------------------------------------------------------

def run(cmd, log_path=None):
    """Run a program of the package (cmd[0] is its name): (its output, the wall time of the call that ran [s]);
    RuntimeError with its output when it fails. A program that cannot be started because it is being rebuilt is
    tried again after RETRY_WAIT_S (the wait is not timed)."""
    for attempt in range(RETRIES + 1):
        try:
            full = [paths.program(cmd[0])] + list(cmd[1:])
            t0 = time.time()
            proc = atomic.run_child(full, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
            wall = time.time() - t0
            break
        except (ValueError, OSError) as e:
            busy = isinstance(e, ValueError) or e.errno in (errno.ETXTBSY, errno.ENOENT, errno.EACCES)
            if not busy or attempt == RETRIES:
                raise RuntimeError('%s: cannot run: %s' % (cmd[0], atomic.error_line(e)))
            log('%s: cannot run it now (%s); trying again in %d s' % (cmd[0], atomic.error_line(e), RETRY_WAIT_S))
            time.sleep(RETRY_WAIT_S)
    if log_path:
        atomic.write_text(log_path, proc.stdout)
    if proc.returncode != 0:
        tail = '\n'.join(proc.stdout.strip().splitlines()[-15:])
        raise RuntimeError('%s failed (exit code %d):\n%s' % (' '.join(cmd), proc.returncode, tail))
    return proc.stdout, wall


def convert(bags, names, out_dir):
    """Write (or reuse) OUT/bags/<name>.bag for each name; returns {name: path}."""
    bag_dir = os.path.join(out_dir, 'bags')
    os.makedirs(bag_dir, exist_ok=True)
    done = {}
    for name in names:
        cmd, inputs = bags[name][:2]
        bag = os.path.join(bag_dir, (bags[name][2] if len(bags[name]) > 2 else name) + '.bag')
        newest = max(os.path.getmtime(f) for f in inputs)
        if os.path.isfile(bag) and os.path.getmtime(bag) > newest:
            log('%s: reusing %s' % (name, bag))
        else:
            log('%s: converting (%s) ...' % (name, cmd[0]))
            _, wall = run(cmd + ['-o', bag])
            log('%s: %s in %.0f s' % (name, bag, wall))
        done[name] = bag
    return done


def slam_command(spec, bag, seed, run_dir, overlay):
    cmd = ['slam_bag', '--bag', bag] + list(spec['input']) + ['--seed', str(seed), '--out', run_dir, '--quiet']
    for c in spec['configs']:
        cmd += ['--config', paths.package_file(*c.split('/'))]
    if spec['known_ids']:
        cmd += ['--config', overlay]
    if spec['extraction_config']:
        cmd += ['--extraction-config', paths.package_file(*spec['extraction_config'].split('/'))]
    return cmd


def one_run(name, spec, bag, seed, robot, out_dir, overlay):
    """slam_bag and evaluate_bag_run for one seed: the run's figures (failed: the error)."""
    parts = [out_dir, name] + (['robot%d' % robot] if robot is not None else []) + ['seed%d' % seed]
    run_dir = os.path.join(*parts)
    fig = {'set': name, 'robot': robot, 'seed': seed, 'run': run_dir, 'bag': bag}
    try:
        if os.path.isdir(run_dir):
            shutil.rmtree(run_dir)  # no file of an earlier run may be scored as this one's
        os.makedirs(run_dir)
        _, wall = run(slam_command(spec, bag, seed, run_dir, overlay), os.path.join(run_dir, 'slam_bag.log'))
        ev_cmd = ['evaluate_bag_run', '--bag', bag, '--run', run_dir, '--quiet']
        if spec['gate']:
            ev_cmd += ['--gate', repr(spec['gate'])]
        run(ev_cmd)
        with open(os.path.join(run_dir, 'evaluation.json')) as f:
            evaluation = json.load(f)
    except (OSError, RuntimeError, ValueError) as e:
        fig.update(failed=True, error=str(e))
        return fig, None
    fig.update(run_figures(evaluation, wall))
    fig['failed'] = False
    return fig, evaluation


def plot_track(run_dir, bag, title, dst):
    """The whole estimated path and the confirmed trees of a run, moved by its evaluation's rigid fit, over the
    reference positions (a GPS: its fixes as dots), written to @p dst: repeated passes should lie on one another."""
    import io
    import math
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from rbpf_slam import evaluate as ev
    with open(os.path.join(run_dir, 'evaluation.json')) as f:
        transform = json.load(f)['estimate']['transform']
    a = math.radians(transform['rotation_deg'])
    r = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    t = np.array(transform['translation'])
    est = ev.read_tum(os.path.join(run_dir, 'estimate.tum'))
    path = np.asarray(est[1]) @ r.T + t
    trees = ev.read_map_csv(os.path.join(run_dir, 'map.csv'))
    ref = ev.read_bag_reference(bag)
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.plot(path[:, 0], path[:, 1], '-', lw=0.6, color='tab:blue', label='FastSLAM (whole path, fitted)')
    if trees is not None and len(trees):
        moved = np.asarray(trees)[:, :2] @ r.T + t
        ax.plot(moved[:, 0], moved[:, 1], '.', ms=3, color='tab:green', label='trees (confirmed)')
    if ref['xy'] is not None:
        ax.plot(ref['xy'][:, 0], ref['xy'][:, 1], '.', ms=2.5, color='k', label='reference fixes')
    ax.set_aspect('equal')
    ax.grid(True)
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_title(title)
    ax.legend(loc='best', fontsize=8)
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=110, bbox_inches='tight')
    plt.close(fig)
    atomic.write_bytes(dst, buf.getvalue())


def _seeds_text(first, count):
    return 'seed %d' % first if count == 1 else 'seeds %d-%d' % (first, first + count - 1)


def main(argv=None):
    """The command: exit code 0; 2 for a bad command line or missing data; 1 when a tool failed."""
    return atomic.run_tool(PROG, _main, argv)


def _main(argv):
    args = parse_args(argv)
    try:
        bags_needed = data_inputs(args.data, args.only, args.robots)
        for name in args.only:
            for c in DATA_SETS[name]['configs'] + ([DATA_SETS[name]['extraction_config']]
                                                   if DATA_SETS[name]['extraction_config'] else []):
                if not os.path.isfile(paths.package_file(*c.split('/'))):
                    raise DataError('%s: %s: no such configuration file' % (name, paths.package_file(c)))
    except (DataError, RuntimeError) as e:
        log(str(e))
        return 2
    try:
        programs = {p: paths.program(p) for p in ('slam_bag', 'evaluate_bag_run', 'victoria_park_to_bag',
                                                   'mrclam_to_bag')}
        built = os.path.getmtime(programs['slam_bag'])
    except (ValueError, OSError) as e:
        log(atomic.error_line(e))
        return 1

    started = time.time()
    out = args.out
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    seeds_text = _seeds_text(args.first_seed, args.seeds)
    os.makedirs(out, exist_ok=True)
    overlay = os.path.join(out, 'known_ids.yaml')
    if any(DATA_SETS[s]['known_ids'] for s in args.only):
        atomic.write_text(overlay, KNOWN_IDS_OVERLAY)

    # The runs to make, in order: (set, robot or None, seed, bag name).
    plan = []
    for name in args.only:
        spec = DATA_SETS[name]
        robots = args.robots if is_mrclam(spec) else [None]
        for robot in robots:
            bag = spec['bag'] + ('%d' % robot if robot is not None else '')
            plan += [(name, robot, seed, bag) for seed in seeds]
    bag_names = sorted(set(p[3] for p in plan), key=lambda b: [p[3] for p in plan].index(b))

    try:
        bags = convert(bags_needed, bag_names, out)
    except (OSError, RuntimeError) as e:
        log('conversion failed: %s' % e)
        return 1

    runs, evaluations = {name: [] for name in args.only}, {}
    for i, (name, robot, seed, bag) in enumerate(plan, 1):
        fig, evaluation = one_run(name, DATA_SETS[name], bags[bag], seed, robot, out, overlay)
        runs[name].append(fig)
        where = '%s%s seed %d' % (name, ' robot %d' % robot if robot is not None else '', seed)
        if fig['failed']:
            log('[%d/%d] %s FAILED: %s' % (i, len(plan), where, fig['error']))
        else:
            log('[%d/%d] %s: ATE %s m (dead reckoning %s m), health warned %s, %.1f s'
                % (i, len(plan), where, '-' if fig['ate'] is None else '%.2f' % fig['ate'],
                   '-' if fig['dr_ate'] is None else '%.2f' % fig['dr_ate'], _pct(fig['health_share']),
                   fig['wall_s']))
            evaluations[fig['run']] = evaluation

    summary = {'data': os.path.abspath(args.data), 'first_seed': args.first_seed, 'seeds': args.seeds,
               'robots': args.robots, 'data_sets': {}}
    texts = []
    for name in args.only:
        spec = DATA_SETS[name]
        table = set_table(runs[name], spec)
        text = format_table(name, spec, table, runs[name],
                            seeds_text + (', robots %s' % ','.join(map(str, args.robots)) if is_mrclam(spec) else ''))
        entry = {'config': spec, 'table': table,
                 'runs': [dict(r, evaluation=evaluations.get(r['run'])) for r in runs[name]]}
        if is_mrclam(spec):
            robots = per_robot(runs[name], spec)
            text += '\n' + format_per_robot(robots)
            entry['per_robot'] = {str(k): v for k, v in robots.items()}
        else:
            scored = [r for r in runs[name] if not r.get('failed') and r.get('ate') is not None]
            if scored:
                for which, r in (('best', min(scored, key=lambda r: r['ate'])),
                                 ('worst', max(scored, key=lambda r: r['ate']))):
                    dst = os.path.join(out, '%s_%s.png' % (name, which))
                    plot_track(r['run'], r['bag'], '%s, seed %d: ATE %.2f m after a rigid fit' % (name, r['seed'],
                                                                                                 r['ate']), dst)
                    entry[which] = {'run': r['run'], 'seed': r['seed'], 'ate': r['ate'], 'png': dst}
                if 'best' in entry and 'worst' in entry:
                    text += ('\nbest run seed %d (ATE %.2f m), worst seed %d (ATE %.2f m): %s_best.png, %s_worst.png'
                             % (entry['best']['seed'], entry['best']['ate'], entry['worst']['seed'],
                                entry['worst']['ate'], name, name))
        texts.append(text)
        summary['data_sets'][name] = entry
    if not args.keep_bags:
        shutil.rmtree(os.path.join(out, 'bags'), ignore_errors=True)
    try:
        rebuilt = os.path.getmtime(paths.program('slam_bag')) != built
    except (ValueError, OSError):
        rebuilt = True
    summary['slam_bag_rebuilt_during_the_runs'] = rebuilt
    if rebuilt:
        log('warning: slam_bag was rebuilt while the benchmark ran: its runs may come from two builds')
    summary['wall_seconds'] = time.time() - started
    summary['tables'] = '\n\n'.join(texts)
    atomic.write_json(os.path.join(out, 'summary.json'), summary, indent=2)
    print(summary['tables'])
    print('\nwall time %.0f s; %s/summary.json' % (summary['wall_seconds'], out))
    failed = sum(1 for name in runs for r in runs[name] if r['failed'])
    if failed:
        log('%d run(s) failed: see above' % failed)
        return 1
    return 0
