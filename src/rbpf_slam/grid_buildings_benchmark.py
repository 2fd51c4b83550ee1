"""Grid SLAM over several buildings' CARMEN logs at once, each beside its raw odometry and, when asked, GMapping
run on the same bags in the same benchmark.

  rosrun rbpf_slam grid_buildings_benchmark LOG [LOG ...] --out DIR [--seeds 0-9] [--every-scan]
      [--config YAML ...] [--convert NAME=ARGS ...] [--gmapping PEER_DIR] [--gmapping-arg KEY=VALUE ...]
      [--jobs N]

For each log (CARMEN, plain or .gz; NAME is its file name without ``-corrected``, ``.gz`` and ``.log``):

1. Converts it once into OUT/bags/NAME.bag with carmen_to_bag (``--convert NAME=ARGS`` adds ARGS, e.g.
   ``--convert infinite-corridor='--line-period 0.1'`` for a log without trustworthy stamps); a bag newer than
   its log is reused.
2. Runs ``slam_bag --filter grid`` once per seed with the node's processing rule (the configs' travel
   thresholds; ``--every-scan`` processes every scan), the shipped configuration unless --config, and one
   thread (``threads: 1`` laid over the configs: one core, as GMapping; the result does not depend on it).
   Outputs in OUT/runs/NAME/seedS.
3. With ``--gmapping PEER_DIR`` (a folder holding GMapping's sources and ``build.sh``, which builds its offline
   harness ``gmap_harness``): builds it once into OUT/gmapping, writes the harness's log of each bag
   (OUT/gmapping/NAME.log: one FLASER line per scan of the bag, with the bag's odometry at the scan's stamp
   and the scan's ranges; readings that are no return, NaN or below range_min are written past the harness's
   maxRange, so GMapping skips them as slam_gmapping does) and runs it once per seed (GMapping's seed = the
   seed + 1; 0 would leave its generator unseeded) with slam_gmapping's defaults (30 particles, travel
   thresholds 1 m / 0.5 rad, maxRange = maxUrange = the scans' range_max - 0.01 m) unless --gmapping-arg.
   Scored on its final best particle's history. ``--gmapping-seeds`` runs it on other seeds (it takes about 5
   times the CPU of the package's filter); a run made before with the same arguments is reused.
4. Scores every run against the bag's reference (the logs' corrected poses) with the package's evaluator (ATE
   RMS after a rigid fit; the rbpf run's best particle's history), and measures each process's CPU time (user
   + system, from the kernel) and peak resident memory (slam_bag's own VmHWM from its timing.json; GMapping's
   VmHWM read from /proc every 0.05 s while it runs).

Prints one line per seed while it runs (stderr) and then a table per log (stdout): median / worst ATE of the
seeds beside the odometry's and GMapping's, the worst seed against GMapping's worst, whether every seed ends
below the odometry's ATE, median CPU seconds and their ratio, the largest peak memory, and the filter's stated
uncertainty: the median standard deviation of the pose the node would publish (the particle cloud carried to each
scan, slam_bag's updates.csv) and the share of the reference positions inside its 95 % region after the rigid fit
of the online estimate (median and worst seed). Writes OUT/summary.json
(every run's figures) and OUT/table.md.

Exit code 0; 1 with one line on stderr when an input is missing or a run fails.
"""
import argparse
import json
import math
import os
import shlex
import subprocess
import sys
import threading
import time

import numpy as np

from rbpf_slam import atomic, evaluate as ev, paths
from rbpf_slam.geometry import yaw_of
from rbpf_slam.grid_benchmark import default_configs, find_slam_bag, median, parse_seeds, worst

#: GMapping's arguments (slam_gmapping's defaults); maxRange / maxUrange come from the bag's scans.
GMAPPING_DEFAULTS = ('particles=30', 'linearUpdate=1', 'angularUpdate=0.5')
#: A reading written here is past any maxRange: GMapping skips it.
SKIPPED_RANGE = 1.0e4
#: How often GMapping's resident memory is read [s].
MEMORY_PERIOD = 0.05


def log_name(path):
    """'intel-corrected.log.gz' -> 'intel'."""
    name = os.path.basename(path)
    for end in ('.gz', '.log', '-corrected'):
        if name.endswith(end):
            name = name[:-len(end)]
    return name


def parse_pairs(specs, option):
    """['NAME=VALUE', ...] -> {NAME: VALUE}; ValueError naming the option for a malformed one."""
    pairs = {}
    for spec in specs:
        name, sep, value = spec.partition('=')
        if not sep or not name or not value:
            raise ValueError('%s %s: expected NAME=VALUE' % (option, spec))
        pairs[name] = value
    return pairs


def run_measured(cmd, stdout=subprocess.DEVNULL, poll_memory=False):
    """Runs a process; returns (exit code, wall [s], CPU [s] user + system, stderr text, peak VmHWM [MB] or
    None). With poll_memory, VmHWM is read from /proc while it runs (the kernel's maximum resident size of a
    child also holds the pages of this process copied at the fork)."""
    started = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=stdout, stderr=subprocess.PIPE)
    peak = [None]
    done = threading.Event()

    def watch():
        status = '/proc/%d/status' % proc.pid
        while not done.is_set():
            try:
                with open(status) as f:
                    for line in f:
                        if line.startswith('VmHWM:'):
                            peak[0] = max(peak[0] or 0.0, float(line.split()[1]) / 1024.0)
            except (OSError, ValueError, IndexError):
                pass
            done.wait(MEMORY_PERIOD)
    watcher = threading.Thread(target=watch, daemon=True) if poll_memory else None
    if watcher:
        watcher.start()
    err = proc.stderr.read().decode('utf-8', 'replace')
    _, status, usage = os.wait4(proc.pid, 0)
    done.set()
    if watcher:
        watcher.join()
    proc.stderr.close()
    proc.returncode = os.waitstatus_to_exitcode(status) if hasattr(os, 'waitstatus_to_exitcode') else status >> 8
    return proc.returncode, time.monotonic() - started, usage.ru_utime + usage.ru_stime, err, peak[0]


def convert(log, name, args, bag_dir):
    """OUT/bags/NAME.bag from a CARMEN log (reused when newer than the log)."""
    bag = os.path.join(bag_dir, name + '.bag')
    if os.path.isfile(bag) and os.path.getmtime(bag) > os.path.getmtime(log):
        progress('%s: reusing %s' % (name, bag))
        return bag
    cmd = [sys.executable, paths.script('carmen_to_bag'), log, '-o', bag, '-q'] + shlex.split(args)
    proc = atomic.run_child(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True)
    if proc.returncode != 0:
        raise ValueError('carmen_to_bag %s failed (exit %d): %s' % (log, proc.returncode,
                                                                   ' '.join(proc.stdout.split())[-400:]))
    progress('%s: converted to %s' % (name, bag))
    return bag


def write_gmapping_log(bag_path, out_path, scan_topic='/scan', odom_topic='/odom'):
    """The harness's CARMEN log of a bag: PARAM robot_frontlaser_offset (the laser's x on the robot, from
    /tf_static) and a FLASER line per scan: its ranges (no return, NaN, below range_min or above range_max ->
    SKIPPED_RANGE), the odometry at its stamp (interpolated between the bag's odometry samples) in both pose
    fields, its stamp. Returns (scans written, the scans' range_max). ValueError for a bag the harness cannot
    take (no scans, no odometry, scans not from -90 degrees over 180 as FLASER, a laser turned on the robot)."""
    import rosbag
    scans, odom, offset, frames = [], [], None, {}
    with rosbag.Bag(bag_path) as bag:
        for topic, msg, _ in bag.read_messages(topics=[scan_topic, odom_topic, '/tf_static']):
            if topic == '/tf_static':
                for tf in msg.transforms:
                    frames[tf.child_frame_id] = tf
            elif topic == odom_topic:
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                odom.append((msg.header.stamp.to_sec(), p.x, p.y, q.x, q.y, q.z, q.w))
            else:
                scans.append(msg)
    if not scans or not odom:
        raise ValueError('%s: expected scans on %s and odometry on %s, got %d and %d messages' % (
            bag_path, scan_topic, odom_topic, len(scans), len(odom)))
    first = scans[0]
    n = len(first.ranges)
    res = math.pi / n if n % 2 == 0 else math.pi / (n - 1)
    if abs(first.angle_min + math.pi / 2) > 1e-4 or abs(first.angle_increment - res) > 1e-6:
        raise ValueError('%s: expected FLASER scans (from -90 deg, %d beams over 180 deg), got angle_min %.4f '
                         'rad, increment %.6f rad' % (bag_path, n, first.angle_min, first.angle_increment))
    laser = frames.get(first.header.frame_id)
    if laser is not None:
        r = laser.transform.rotation
        if abs(r.z) > 1e-6 or abs(r.x) > 1e-6 or abs(r.y) > 1e-6 or abs(laser.transform.translation.y) > 1e-6:
            raise ValueError('%s: the harness takes a laser on the robot\'s x axis, facing forward' % bag_path)
        offset = laser.transform.translation.x
    odom = np.array(sorted(odom))
    stamps = [msg.header.stamp.to_sec() for msg in scans]
    xy, yaw = ev.interpolate(odom[:, 0], odom[:, 1:3], yaw_of(odom[:, 3:7]), stamps)
    lines = ['PARAM robot_frontlaser_offset %.6f' % (offset or 0.0)]
    for msg, t, p, th in zip(scans, stamps, xy, yaw):
        if len(msg.ranges) != n:
            continue  # the harness skips them too; say nothing twice
        pose = (p[0], p[1], math.atan2(math.sin(th), math.cos(th)))
        ranges = ['%.3f' % r if (r == r and msg.range_min <= r <= msg.range_max) else '%.0f' % SKIPPED_RANGE
                  for r in msg.ranges]
        lines.append('FLASER %d %s %.6f %.6f %.6f %.6f %.6f %.6f %.6f nohost %.6f' % (
            (n, ' '.join(ranges)) + tuple(pose) + tuple(pose) + (t, t)))
    atomic.write_text(out_path, '\n'.join(lines) + '\n')
    return len(lines) - 1, float(first.range_max)


def gmapping_log(bag, path):
    """write_gmapping_log's (scans, range_max), the log written once: reused (with PATH.json) while newer than
    the bag."""
    sidecar = path + '.json'
    if os.path.isfile(sidecar) and os.path.isfile(path) and os.path.getmtime(path) > os.path.getmtime(bag):
        with open(sidecar) as f:
            kept = json.load(f)
        return kept['scans'], kept['range_max']
    scans, range_max = write_gmapping_log(bag, path)
    atomic.write_json(sidecar, {'scans': scans, 'range_max': range_max})
    return scans, range_max


def build_gmapping(peer_dir, out_dir):
    """OUT/gmapping/gmap_harness, built by PEER_DIR/build.sh (once)."""
    harness = os.path.join(out_dir, 'gmap_harness')
    if os.path.isfile(harness) and os.access(harness, os.X_OK):
        return harness
    script = os.path.join(peer_dir, 'build.sh')
    if not os.path.isfile(script):
        raise ValueError('--gmapping %s: expected a folder with build.sh, got none' % peer_dir)
    progress('gmapping: building from %s (a minute or two) ...' % peer_dir)
    proc = atomic.run_child(['bash', script, out_dir], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            universal_newlines=True)
    if proc.returncode != 0 or not os.path.isfile(harness):
        raise ValueError('gmapping: build.sh failed (exit %d): %s' % (proc.returncode,
                                                                     ' '.join(proc.stdout.split())[-400:]))
    return harness


def progress(text):
    sys.stderr.write('grid_buildings_benchmark: %s\n' % text)
    sys.stderr.flush()


def _score(trajectory, ref):
    return ev.trajectory_errors(ev.read_trajectory(trajectory), ref, 1.0, 1e-3)


def stated_coverage(folder, ref):
    """The filter's stated uncertainty against its error: the share of the reference positions inside the 95 %
    region of the pose the node would publish at the nearest scan (updates.csv: the particle cloud's mean and
    covariance), after the rigid fit of the online estimate (estimate.tum) onto the reference; and the median of
    the stated position standard deviation sqrt(trace / 2) [m]. (None, None) without updates.csv."""
    updates = ev.read_updates_csv(os.path.join(folder, 'updates.csv'))
    if updates is None:
        return None, None
    run_t, run_xy, _ = ev.read_trajectory(os.path.join(folder, 'estimate.tum'))
    i, j = ev.match_by_stamp(run_t, ref[0], 1e-3)
    r, t = ev.fit_rigid_2d(np.asarray(run_xy, float)[i], np.asarray(ref[1], float)[j])
    share, _ = ev.coverage_95(updates, ref[0], ref[1], r, t, region='estimate')
    sigma = np.sqrt(np.maximum(0.5 * (updates['estimate_xx'] + updates['estimate_yy']), 0.0))
    sigma = sigma[np.isfinite(sigma)]
    return share, (float(np.median(sigma)) if len(sigma) else None)


def run_ours(slam_bag, bag, seed, folder, configs, every_scan):
    cmd = [slam_bag, '--filter', 'grid', '--bag', bag, '--seed', str(seed), '--out', folder, '--quiet']
    for c in configs:
        cmd += ['--config', c]
    if every_scan:
        cmd.append('--every-scan')
    code, wall, cpu, err, _ = run_measured(cmd)
    if code != 0:
        raise ValueError('slam_bag %s seed %d failed (exit %d): %s' % (bag, seed, code, err.strip()[-300:]))
    with open(os.path.join(folder, 'timing.json')) as f:
        timing = json.load(f)
    scored = os.path.join(folder, 'estimate_best_history.tum')
    if not os.path.isfile(scored):
        scored = os.path.join(folder, 'estimate.tum')
    return {'seed': seed, 'wall': wall, 'cpu': cpu, 'peak_mb': timing.get('peak_rss_mb'), 'trajectory': scored,
            'odometry': os.path.join(folder, 'odometry.tum')}


def run_gmapping(harness, log, prefix, seed, extra):
    """One GMapping run; reused (PREFIX.json) when run before with the same arguments on the same log."""
    cmd = [harness, log, prefix, 'seed=%d' % (seed + 1)] + list(extra)
    record = prefix + '.json'
    if os.path.isfile(record) and os.path.getmtime(record) > os.path.getmtime(log):
        with open(record) as f:
            kept = json.load(f)
        if kept.get('command') == cmd[1:]:
            return kept['run']
    with open(prefix + '.stdout', 'w') as out:
        code, wall, cpu, err, peak = run_measured(cmd, stdout=out, poll_memory=True)
    if code != 0:
        raise ValueError('gmap_harness %s seed %d failed (exit %d): %s' % (log, seed, code, err.strip()[-300:]))
    run = {'seed': seed, 'wall': wall, 'cpu': cpu, 'peak_mb': peak, 'trajectory': prefix + '_best_history.tum'}
    atomic.write_json(record, {'command': cmd[1:], 'run': run})
    return run


def _fmt(v, spec='%.3f'):
    return spec % v if v is not None and not (isinstance(v, float) and math.isnan(v)) else '-'


def _ratio(ours, theirs):
    """'5.0x less' where ours costs a fifth of theirs, '1.4x more' where it costs 1.4 times as much."""
    if not ours or not theirs:
        return '-'
    return '%.1fx less' % (theirs / ours) if theirs >= ours else '%.1fx more' % (ours / theirs)


def table(results, with_gmapping):
    head = ['log', 'scans', 'ours ATE m median / worst', 'odometry ATE m', 'every seed below odometry']
    if with_gmapping:
        head += ['GMapping ATE m median / worst', 'worst / GMapping worst']
    head += ['CPU s ours' + (' / GMapping, ratio' if with_gmapping else ''),
             'peak MB ours' + (' / GMapping' if with_gmapping else ''),
             'stated sigma m, coverage of its 95 % region, median / worst']
    rows = ['| ' + ' | '.join(head) + ' |', '|' + '---|' * len(head)]
    for name, r in results.items():
        ours = [s['ate'] for s in r['ours']]
        cells = [name, '%d (%s processed)' % (r['scans'], _fmt(median([s['poses'] for s in r['ours']]), '%.0f')),
                 '%s / %s' % (_fmt(median(ours)), _fmt(worst(ours))), _fmt(r['odometry_ate']),
                 '%d of %d' % (sum(1 for a in ours if a < r['odometry_ate']), len(ours))]
        cpu = median([s['cpu'] for s in r['ours']])
        peak = worst([s['peak_mb'] for s in r['ours']])
        if with_gmapping:
            gm = [s['ate'] for s in r['gmapping']]
            gcpu = median([s['cpu'] for s in r['gmapping']])
            cells += ['%s / %s' % (_fmt(median(gm)), _fmt(worst(gm))),
                      _fmt(worst(ours) / worst(gm) if worst(gm) else None, '%.2f'),
                      '%s / %s, %s' % (_fmt(cpu, '%.1f'), _fmt(gcpu, '%.1f'), _ratio(cpu, gcpu)),
                      '%s / %s' % (_fmt(peak, '%.0f'), _fmt(worst([s['peak_mb'] for s in r['gmapping']]), '%.0f'))]
        else:
            cells += [_fmt(cpu, '%.1f'), _fmt(peak, '%.0f')]
        cover = [s.get('coverage_95') for s in r['ours']]
        cells.append('%s, %s / %s' % (_fmt(median([s.get('stated_sigma') for s in r['ours']])),
                                      _fmt(median(cover), '%.3f'),
                                      _fmt(min([c for c in cover if c is not None], default=None), '%.3f')))
        rows.append('| ' + ' | '.join(cells) + ' |')
    return '\n'.join(rows)


def main(argv=None):
    return atomic.run_tool('grid_buildings_benchmark', _main, argv, errors=(ValueError,))


def _main(argv):
    p = argparse.ArgumentParser(prog='grid_buildings_benchmark', description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('logs', nargs='+', metavar='LOG', help='CARMEN logs (plain or .gz) with corrected poses')
    p.add_argument('--out', required=True, metavar='DIR', help='work and result folder (bags, runs, summary)')
    p.add_argument('--seeds', default='0-9', help='seeds, e.g. 0-9 or 1,4 (default 0-9)')
    p.add_argument('--config', action='append', default=None, metavar='YAML',
                   help='filter configs, in order (default: the shipped config/grid_slam_advanced.yaml then '
                        'config/grid_slam.yaml)')
    p.add_argument('--every-scan', action='store_true', help='process every scan (default: the travel thresholds)')
    p.add_argument('--convert', action='append', default=[], metavar='NAME=ARGS',
                   help='more carmen_to_bag arguments for one log, e.g. infinite-corridor=\'--line-period 0.1\'')
    p.add_argument('--gmapping', metavar='PEER_DIR', help='GMapping\'s folder with build.sh: run it beside')
    p.add_argument('--gmapping-seeds', metavar='SEEDS',
                   help='GMapping\'s seeds (default: --seeds); each run is kept in OUT and reused')
    p.add_argument('--gmapping-arg', action='append', default=[], metavar='KEY=VALUE',
                   help='a harness argument over slam_gmapping\'s defaults (e.g. particles=30)')
    p.add_argument('--jobs', type=int, default=1, help='runs at once (default 1)')
    p.add_argument('--slam-bag', help='the runner (default: the built slam_bag)')
    args = p.parse_args(argv)
    seeds = parse_seeds(args.seeds)
    gmapping_seeds = parse_seeds(args.gmapping_seeds) if args.gmapping_seeds else seeds
    configs = args.config or default_configs()
    names = [log_name(log) for log in args.logs]
    for path in args.logs + configs:
        if not os.path.isfile(path):
            raise ValueError('%s: expected a file, got none' % path)
    if len(set(names)) != len(names):
        raise ValueError('two logs with the same name: %s' % ', '.join(names))
    convert_args = parse_pairs(args.convert, '--convert')
    for name in convert_args:
        if name not in names:
            raise ValueError('--convert %s: no log of that name (%s)' % (name, ', '.join(names)))
    parse_pairs(args.gmapping_arg, '--gmapping-arg')
    slam_bag = find_slam_bag(args.slam_bag)

    out = args.out
    for sub in ('bags', 'runs', 'gmapping'):
        os.makedirs(os.path.join(out, sub), exist_ok=True)
    one_thread = os.path.join(out, 'one_thread.yaml')
    atomic.write_text(one_thread, 'threads: 1\n')
    configs = configs + [one_thread]
    harness = build_gmapping(args.gmapping, os.path.join(out, 'gmapping')) if args.gmapping else None

    from concurrent.futures import ThreadPoolExecutor
    results = {}
    for log, name in zip(args.logs, names):
        bag = convert(log, name, convert_args.get(name, ''), os.path.join(out, 'bags'))
        ref_t, ref_xy, ref_yaw, _ = ev.read_bag_truth(bag, '/ground_truth/odom')
        ref = (ref_t, ref_xy, ref_yaw)
        jobs = []
        for seed in seeds:
            folder = os.path.join(out, 'runs', name, 'seed%d' % seed)
            jobs.append(('ours', seed, lambda s=seed, f=folder: run_ours(slam_bag, bag, s, f, configs,
                                                                            args.every_scan)))
        scans = None
        if harness:
            gm_log = os.path.join(out, 'gmapping', name + '.log')
            scans, range_max = gmapping_log(bag, gm_log)
            reach = '%.3f' % (range_max - 0.01)
            extra = list(GMAPPING_DEFAULTS) + ['maxRange=' + reach, 'maxUrange=' + reach] + args.gmapping_arg
            os.makedirs(os.path.join(out, 'runs', name, 'gmapping'), exist_ok=True)
            for seed in gmapping_seeds:
                prefix = os.path.join(out, 'runs', name, 'gmapping', 'seed%d' % seed)
                jobs.append(('gmapping', seed, lambda s=seed, pr=prefix: run_gmapping(harness, gm_log, pr, s,
                                                                                        extra)))
        with ThreadPoolExecutor(max(1, args.jobs)) as pool:
            outcomes = list(pool.map(lambda job: job[2](), jobs))
        entry = {'bag': bag, 'ours': [], 'gmapping': []}
        for (who, seed, _), run in zip(jobs, outcomes):
            run.update(_score(run['trajectory'], ref))
            if who == 'ours':
                run['coverage_95'], run['stated_sigma'] = stated_coverage(os.path.dirname(run['trajectory']), ref)
            entry[who].append(run)
            progress('%s %s seed %d: ATE %.3f m, CPU %.1f s, peak %s MB' % (
                name, who, seed, run['ate'], run['cpu'], _fmt(run['peak_mb'], '%.0f')))
        odometry = _score(entry['ours'][0]['odometry'], ref)
        entry['odometry_ate'] = odometry['ate']
        entry['scans'] = scans if scans is not None else len(ev.read_trajectory(entry['ours'][0]['odometry'])[0])
        results[name] = entry
    text = table(results, bool(harness))
    print(text)
    atomic.write_text(os.path.join(out, 'table.md'), text + '\n')
    atomic.write_json(os.path.join(out, 'summary.json'), results, indent=1, default=float)
    return 0
