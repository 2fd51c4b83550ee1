"""The shared bag runner with the grid filter (slam_bag --filter grid).

- The ESE 650 lidar path: a run written here in the data set's exact .mat layout (Encoders, Hokuyo: a straight
  corridor), converted by ese650_to_bag, mapped from wheel odometry: every scan is used (--every-scan: the drive
  is about the default travel threshold, 1 m) and the walls land where they are.
- The travel thresholds: by default a scan is processed after 1 m or 0.5 rad; --every-scan processes every scan
  whatever the --config files say; the summary line and the timing files say which, with the maps' memory.
- The truth stays out: a simulated indoor drive and the same bag with every ground-truth topic stripped give
  byte-identical output.
- trajectory_eval scores the run's TUM files against the bag's reference (the package's one evaluator).
"""
import filecmp
import importlib
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
from bagcheck import built_tool

from bagcheck import run_main
from test_ese650 import T0, write_run

rosbag = pytest.importorskip('rosbag')
from rbpf_slam import ese650  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


_tool = built_tool
#: The evaluator as in this source tree (a built workspace's copy may be another tree's).
TRAJECTORY_EVAL = [sys.executable, os.path.join(ROOT, 'scripts', 'trajectory_eval')]


def _plot_module():
    return importlib.import_module('rbpf_slam.plot_grid_run')


def corridor_hokuyo(scan_ts, laser_x):
    """Hokuyo0 (ranges 1081 x S, angles 1081 x 1, ts 1 x S) in a corridor: walls at y = +-1 m, an end wall
    at x = 6 m; @p laser_x: the laser's x at each scan (the robot drives along the corridor's axis)."""
    angles = np.radians(np.linspace(-135.0, 135.0, 1081))
    ranges = np.empty((1081, len(scan_ts)))
    for k, lx in enumerate(laser_x):
        s, c = np.sin(angles), np.cos(angles)
        with np.errstate(divide='ignore'):
            side = np.where(np.abs(s) > 1e-9, 1.0 / np.abs(s), np.inf)
            end = np.where(c > 1e-9, (6.0 - lx) / c, np.inf)
        ranges[:, k] = np.minimum(side, end)
    ranges[ranges > 30.0] = 65.0  # what the UTM-30LX reports beyond its range (converted to +Inf)
    return {'ranges': ranges, 'angles': angles.reshape(-1, 1), 'ts': np.asarray(scan_ts).reshape(1, -1)}


def test_ese650_lidar_path_on_a_hokuyo_file(tmp_path, capsys):
    k = 160  # 4 s of encoder reads at 40 Hz, 3 counts per wheel per read: 1.06 m straight ahead
    ts = T0 + 0.025 * np.arange(k)
    counts = np.full((4, k), 3)
    counts[:, 0] = 0
    travel = np.cumsum(counts[0]) * ese650.METRES_PER_COUNT
    scan_ts = ts[1::4] + 0.001
    laser_x = np.interp(scan_ts, ts, travel) + 0.1332  # the converter's laser mount: 0.1332 m ahead
    d = write_run(tmp_path / 'run', counts, ts, imu=False, hokuyo=corridor_hokuyo(scan_ts, laser_x))
    bag = str(tmp_path / 'ese.bag')
    code, stdout, _ = run_main(ese650.main, [d, '7', '-o', bag, '-q'], capsys)
    assert code == 0, stdout
    out = str(tmp_path / 'out')
    r = subprocess.run([_tool('slam_bag'), '--filter', 'grid', '--bag', bag, '--wheels', '/wheel_ticks', '--out', out,
                        '--seed', '1', '--every-scan'], stdout=subprocess.PIPE, universal_newlines=True, check=True)
    assert '%d scans, 0 scans dropped' % len(scan_ts) in r.stdout, r.stdout
    assert '%d processed (every scan' % len(scan_ts) in r.stdout, r.stdout
    est = np.loadtxt(os.path.join(out, 'estimate.tum'), ndmin=2)
    odo = np.loadtxt(os.path.join(out, 'odometry.tum'), ndmin=2)
    assert len(est) == len(scan_ts)
    assert est[-1, 1] == pytest.approx(odo[-1, 1], abs=0.1)
    assert abs(est[-1, 2]) < 0.05
    plot = _plot_module()
    res, origin, image = plot.read_map_yaml(os.path.join(out, 'map.yaml'))
    img = plot.read_pgm(image)[::-1]  # row 0 at the bottom
    occ = np.argwhere(img == 0)
    y = origin[1] + (occ[:, 0] + 0.5) * res
    x = origin[0] + (occ[:, 1] + 0.5) * res
    on_walls = (np.abs(np.abs(y) - 1.0) < 0.1) | (np.abs(x - 6.0) < 0.1)
    assert len(occ) > 100 and on_walls.mean() > 0.95, '%d occupied, %.2f on the walls' % (len(occ), on_walls.mean())
    # The plot of the run renders.
    png = str(tmp_path / 'map.png')
    assert plot.main([out, '--out', png]) == 0 and os.path.getsize(png) > 1000


def _record_indoor_drive(tmp_path, name):
    """A simulated 8 m drive along the indoor world's south corridor (seed 2), recorded to tmp_path/name."""
    wp = tmp_path / 'wp.txt'
    wp.write_text('4 0\n8 0\n')
    start = tmp_path / 'start.yaml'
    start.write_text('start: {x: 0.0, y: 0.0, yaw_deg: 0.0}\n')
    bag = str(tmp_path / name)
    subprocess.run([_tool('record_scenario'), '--indoor-map', os.path.join(ROOT, 'config', 'worlds', 'indoor.yaml'),
                    '--config', str(start), '--drive', str(wp), '--seed', '2', '--no-points', '--out', bag,
                    '--quiet'], check=True, stdout=subprocess.DEVNULL)
    return bag


def test_grid_truth_stripped_gives_identical_output(tmp_path):
    full = _record_indoor_drive(tmp_path, 'full.bag')
    stripped = str(tmp_path / 'stripped.bag')
    with rosbag.Bag(full) as src, rosbag.Bag(stripped, 'w') as dst:
        for topic, msg, t in src.read_messages(raw=True):
            if not topic.startswith('/ground_truth'):
                dst.write(topic, msg, t, raw=True)
    outs = []
    for bag in (full, stripped):
        out = bag + '.out'
        subprocess.run([_tool('slam_bag'), '--filter', 'grid', '--bag', bag, '--out', out, '--seed', '5', '--quiet'],
                       check=True)
        outs.append(out)
    for name in ('estimate.tum', 'odometry.tum', 'map.pgm', 'map.yaml'):
        assert filecmp.cmp(os.path.join(outs[0], name), os.path.join(outs[1], name), shallow=False), name
    assert len(np.loadtxt(os.path.join(outs[0], 'estimate.tum'), ndmin=2)) > 100


def _timing(out):
    with open(os.path.join(out, 'timing.json')) as f:
        timing = json.load(f)
    with open(os.path.join(out, 'timing.txt')) as f:
        text = dict(line.split() for line in f if line.strip())
    return timing, text


def test_travel_thresholds_every_scan_and_the_memory_report(tmp_path):
    bag = _record_indoor_drive(tmp_path, 'indoor.bag')
    advanced_yaml = os.path.join(ROOT, 'config', 'grid_slam_advanced.yaml')
    grid_yaml = os.path.join(ROOT, 'config', 'grid_slam.yaml')
    single_yaml = os.path.join(ROOT, 'config', 'grid_single_map.yaml')
    far = tmp_path / 'far.yaml'
    far.write_text('linear_update: 20.0\nangular_update: 3.0\ntemporal_update: 100.0\n')

    def run(name, *args):
        out = str(tmp_path / name)
        r = subprocess.run([_tool('slam_bag'), '--filter', 'grid', '--bag', bag, '--out', out, '--seed', '5'] +
                           list(args), stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
        assert r.returncode == 0, r.stderr
        summary = r.stdout.splitlines()[0]
        scans, processed = [int(w) for w in re.match(r'.*: (\d+) scans, .* (\d+) processed \(', summary).groups()]
        return out, r.stdout, scans, processed

    # The defaults (no file): a scan per metre of the 8 m drive, and the summary names the thresholds.
    out, stdout, scans, processed = run('defaults')
    assert scans > 300 and 8 <= processed <= 10, stdout
    assert 'below the travel thresholds 1 m, 0.5 rad)' in stdout, stdout
    timing, text = _timing(out)
    assert (timing['updates'], timing['linear_update'], timing['angular_update'], timing['temporal_update']) == \
        (processed, 1.0, 0.5, 0.0)
    assert text['processed'] == str(processed) and text['linear_update'] == '1'
    # --every-scan: every scan, whatever the files given (before or after it) set, the single-map overlay included.
    printed = {}
    for name, args in (('every', ['--every-scan', '--config', advanced_yaml, '--config', grid_yaml,
                                  '--config', single_yaml]),
                       ('every_over_files', ['--every-scan', '--config', advanced_yaml, '--config', grid_yaml,
                                             '--config', str(far), '--particles', '3']),
                       ('every_first', ['--config', str(far), '--every-scan'])):
        out, stdout, scans, processed = run(name, *args)
        printed[name] = stdout
        assert processed == scans > 300, stdout
        assert '(every scan: --every-scan turned the travel thresholds off)' in stdout, stdout
        timing, _ = _timing(out)
        assert (timing['linear_update'], timing['angular_update'], timing['temporal_update']) == (0.0, 0.0, 0.0)
    # Without --every-scan the far file's thresholds hold: only the first scan.
    _, stdout, _, processed = run('far', '--config', str(far))
    assert processed == 1 and 'travel thresholds 20 m, 3 rad, 100 s)' in stdout, stdout
    # The memory report (rbpf, 3 particles, every scan): distinct tiles, MB, the best map's area in whole tiles
    # of 3.2 m x 3.2 m, MB per particle per 1000 m^2 - printed and in both timing files.
    timing, text = _timing(str(tmp_path / 'every_over_files'))
    tiles, mb, area = timing['map_tiles'], timing['map_mb'], timing['best_map_area_m2']
    assert tiles > 0 and mb > 0.0 and area > 0.0
    best_tiles = area / (3.2 * 3.2)
    assert abs(best_tiles - round(best_tiles)) < 1e-6 and 0 < best_tiles <= tiles
    assert timing['mb_per_particle_per_1000m2'] == pytest.approx(mb / 3 / (area / 1000.0), rel=1e-9)
    assert int(text['map_tiles']) == tiles and float(text['map_mb']) == pytest.approx(mb, rel=1e-9)
    assert float(text['best_map_area_m2']) == pytest.approx(area, rel=1e-9)
    assert float(text['mb_per_particle_per_1000m2']) == pytest.approx(timing['mb_per_particle_per_1000m2'], rel=1e-9)
    # The runner's own peak memory (VmHWM): a grid run does not load FastSLAM's libraries (PCL alone took ~35 MB).
    assert 5.0 < timing['peak_rss_mb'] < 200.0 and float(text['peak_rss_mb']) == pytest.approx(timing['peak_rss_mb'])
    assert 'map memory: %d distinct tiles (shared tiles once) in %.2f MB; best map %d tiles, %.0f m^2; %.3f MB per ' \
        'particle per 1000 m^2 of map' % (tiles, mb, round(best_tiles), area,
                                          timing['mb_per_particle_per_1000m2']) in printed['every_over_files'], \
        printed['every_over_files']


def test_trajectory_eval_scores_a_run_against_the_bags_reference(tmp_path):
    bag = _record_indoor_drive(tmp_path, 'indoor.bag')
    out = str(tmp_path / 'run')
    subprocess.run([_tool('slam_bag'), '--filter', 'grid', '--bag', bag, '--out', out, '--seed', '5', '--quiet'],
                   check=True)
    reference = str(tmp_path / 'reference.tum')
    files = [os.path.join(out, 'estimate.tum'), os.path.join(out, 'odometry.tum')]
    r = subprocess.run(TRAJECTORY_EVAL + ['--bag', bag, '--tolerance', '0.011', '--write-reference', reference]
                       + files, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].split() == ['trajectory', 'poses', 'RPE', 'm', 'RPE', 'deg', 'RPErms', 'm', 'RPErms', 'deg',
                                'ATEfit', 'm', 'ATEfirst', 'm']
    rows = {line.split()[0]: [float(v) for v in line.split()[1:]] for line in lines[1:]}
    assert sorted(rows) == sorted(files)
    scans = len(np.loadtxt(files[0], ndmin=2))
    est, odo = rows[files[0]], rows[files[1]]
    assert scans - 2 <= est[0] <= scans, 'scan poses matched to a reference pose within 11 ms'
    assert 0.0 < est[5] < 0.1, 'ATE after the fit [m]'
    assert est[5] <= est[6] < 0.2, 'ATE aligned at the first pose [m]'
    assert 0.0 < est[1] <= est[3] < 0.1, 'RPE mean <= RMS [m]'
    assert odo[0] == est[0] and odo[5] > 0.0
    # The reference written is the bag's /ground_truth/odom, pose for pose.
    with rosbag.Bag(bag) as b:
        truth = [(m.header.stamp.to_sec(), m.pose.pose.position.x, m.pose.pose.position.y)
                 for _, m, _ in b.read_messages(topics=['/ground_truth/odom'])]
    written = np.loadtxt(reference, ndmin=2)
    assert written.shape == (len(truth), 8)
    assert np.allclose(written[:, :3], truth, atol=1e-9)
    # A bag without that topic, or a file that is no trajectory: one line, exit 1.
    r = subprocess.run(TRAJECTORY_EVAL + ['--bag', bag, '--truth', '/nope'] + files,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 1 and r.stderr.strip().splitlines() == [
        'trajectory_eval: %s: no nav_msgs/Odometry on /nope (the reference)' % bag], r.stderr
    r = subprocess.run(TRAJECTORY_EVAL + ['--bag', bag, os.path.join(out, 'map.yaml')],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1 and 'map.yaml' in r.stderr, r.stderr


def test_grid_benchmark_scores_seeds_odometry_and_a_peer(tmp_path):
    bag = _record_indoor_drive(tmp_path, 'indoor.bag')
    # A peer that is the reference itself (paired by index, pose for pose): it must score 0.
    with rosbag.Bag(bag) as b:
        scans = [m.header.stamp.to_sec() for _, m, _ in b.read_messages(topics=['/scan'])]
        truth = [(m.header.stamp.to_sec(), m.pose.pose.position.x, m.pose.pose.position.y,
                  2.0 * np.arctan2(m.pose.pose.orientation.z, m.pose.pose.orientation.w))
                 for _, m, _ in b.read_messages(topics=['/ground_truth/odom'])]
    peer = tmp_path / 'peer.txt'
    peer.write_text(''.join('%.9f %.9f %.9f %.9f\n' % p for p in truth))
    keep = str(tmp_path / 'runs')
    r = subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', 'grid_benchmark'), '--bag', bag,
                        '--seeds', '1,2', '--tolerance', '0.011', '--keep', keep, '--slam-bag', _tool('slam_bag'),
                        '--peer', 'self=%s' % peer, '--peer-time', 'self=1,2'],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 0, r.stderr
    rows = {line[:22].strip(): line[22:].split() for line in r.stdout.splitlines()[2:] if line[:22].strip()}
    assert {'seed 1', 'seed 2', 'median', 'worst', 'odometry', 'self (given)'} <= set(rows), r.stdout
    for seed in (1, 2):
        ate_fit, ate_first = float(rows['seed %d' % seed][0]), float(rows['seed %d' % seed][1])
        assert 0.0 < ate_fit <= ate_first < 0.3
        assert os.path.isfile(os.path.join(keep, 'seed%d' % seed, 'estimate_best_history.tum'))
    assert float(rows['worst'][0]) == max(float(rows['seed 1'][0]), float(rows['seed 2'][0]))
    assert float(rows['odometry'][0]) > float(rows['worst'][0]), 'the filter beats dead reckoning'
    assert float(rows['self (given)'][0]) < 1e-6 and rows['self (given)'][4] == '1.0'
    assert len(scans) > 100
    # The runner refused (a bag that does not exist): one line, exit 1.
    r = subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', 'grid_benchmark'), '--bag',
                        str(tmp_path / 'none.bag')], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    assert r.returncode == 1 and len(r.stderr.strip().splitlines()) == 1 and 'none.bag' in r.stderr, r.stderr
