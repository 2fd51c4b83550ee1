"""lego_to_bag: odometry from track ticks, scans, truth frames; malformed logs; the real robot4 logs."""
import math
import os
import subprocess

import numpy as np
import pytest

from bagcheck import (assert_stamps_monotonic, built_tool, connection_latched, data_path, frames_of, pose2, read_bag,
                      run_main, static_transforms)
from rbpf_slam import convert_common as cc
from rbpf_slam import lego

pytest.importorskip('rosbag')


def test_straight_drive_and_turn_in_place():
    # 1000 ticks on both tracks: 0.349 m straight ahead
    x, y, th, _, _ = lego.odometry_from_ticks([0, 1000], [0, 1000])
    assert (x[-1], y[-1], th[-1]) == pytest.approx((0.349, 0.0, 0.0))
    # opposite ticks turn on the spot by 2 * ticks * 0.349 mm / 155 mm
    x, y, th, _, _ = lego.odometry_from_ticks([0, -100], [0, 100])
    assert (x[-1], y[-1]) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert th[-1] == pytest.approx(2 * 100 * 0.349 / 155.0)


def test_arcs_close_a_circle():
    # right track faster: a constant-curvature arc; a whole circle in N steps ends where it began
    n = 48
    dth = 2 * math.pi / n
    r = 0.5
    ds = r * dth
    x, y, th = cc.integrate_arcs(np.full(n, ds), np.full(n, dth))
    assert (x[-1], y[-1]) == pytest.approx((0.0, 0.0), abs=1e-12)
    assert x[n // 4 - 1] == pytest.approx(r, abs=1e-12) and y[n // 4 - 1] == pytest.approx(r, abs=1e-12)


def test_arena_to_start_frame():
    start = lego.start_robot_pose()
    # the scanner's start position is 30 mm ahead of the robot centre
    sx, sy = lego.arena_to_start(1.850, 1.897)
    assert (sx, sy) == pytest.approx((0.030, 0.0), abs=1e-12)
    assert start[2] == pytest.approx(math.radians(213.0))


def test_the_robot_constants_come_from_the_one_robot_file(tmp_path):
    assert lego.robot_file().endswith(os.path.join('config', 'lego', 'robot.yaml'))
    robot = lego.read_robot()
    assert (lego.TICK, lego.TRACK, lego.SCANNER_X, lego.SCANNER_YAW) == (
        robot['tick'], robot['track'], robot['scanner_x'], robot['scanner_yaw'])
    assert robot['start_scanner_pose'] == pytest.approx((1.850, 1.897, math.radians(213.0)))
    bad = tmp_path / 'robot.yaml'
    bad.write_text('tick: 0.000349\ntrack: 0.155\n')
    with pytest.raises(ValueError, match='robot.yaml: missing key.*scanner_x'):
        lego.read_robot(str(bad))


def test_lego_trunks_reads_the_robot_file(tmp_path):
    """The C++ tool takes its constants from the same file as the converter (--robot: another one)."""
    d = write_logs(tmp_path / 'logs')
    r = subprocess.run([built_tool('lego_trunks'), '--data', d], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    assert r.returncode == 0 and '2 scans' in r.stdout, r.stdout + r.stderr
    bad = tmp_path / 'robot.yaml'
    bad.write_text('tick: 0.000349\n')
    r = subprocess.run([built_tool('lego_trunks'), '--data', d, '--robot', str(bad)], stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 1 and r.stderr.strip() == "lego_trunks: %s: missing key 'track'" % bad, r.stderr


def write_logs(d, motors=None, scans=None, reference=None, landmarks=None):
    d.mkdir(exist_ok=True)
    ranges = ' '.join(['500'] * 10 + ['15'] + ['700'] * 649)
    motors = motors if motors is not None else (
        'M 100 0 0 3000 0 0 0 3000 0 0 0 6000 0\r\n'
        'M 200 1000 0 3000 0 1000 0 3000 0 0 0 6000 0\r\n'
        'M 200 1100 0 3000 0 1100 0 3000 0 0 0 6000 0\r\n'
        'M 300 1200 0 3000 0 1200 0 3000 0 0 0 6000 0\r\n')
    scans = scans if scans is not None else ''.join('S %d 660 %s\r\n' % (t, ranges) for t in (150, 250, 350))
    reference = reference if reference is not None else 'P 120 1850 1897\r\nP 320 1900 1897\r\n'
    landmarks = landmarks if landmarks is not None else 'L C 1291.0\t1881.0\t55.0\r\nL C 482.0\t682.0\t55.0'
    for name, text in (('robot4_motors.txt', motors), ('robot4_scan.txt', scans),
                       ('robot4_reference.txt', reference), ('robot_arena_landmarks.txt', landmarks)):
        (d / name).write_text(text)
    return str(d)


def test_synthetic_logs(tmp_path, capsys):
    d = write_logs(tmp_path / 'logs')
    out = str(tmp_path / 'l.bag')
    code, stdout, _ = run_main(lego.main, [d, '-o', out, '-q'], capsys)
    assert code == 0
    assert '1  motor records repeating the stamp of the one before' in stdout
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    odom = [pose2(m) for _, m in bag['/odom']]
    assert [t for t, _ in bag['/odom']] == pytest.approx(np.array([0.1, 0.2, 0.3]) + lego.SCAN_LATENCY)
    assert odom[1][0] == pytest.approx(1.1 * 0.349) and odom[2][0] == pytest.approx(1.2 * 0.349)
    scan = bag['/scan'][0][1]
    assert len(scan.ranges) == 660 and scan.ranges[0] == pytest.approx(0.5) and math.isnan(scan.ranges[10])
    assert scan.angle_min == pytest.approx(-330 * 0.006135923151543)
    assert scan.range_min == pytest.approx(0.02) and scan.header.frame_id == 'laser'
    mount = static_transforms(bag)[('base_link', 'laser')]
    assert mount.transform.translation.x == pytest.approx(0.03)
    assert pose2(mount)[2] == pytest.approx(-0.0698132)
    lm = bag['/ground_truth/landmarks'][0][1]
    assert lm.header.frame_id == 'map' and [t.radius for t in lm.trunks] == pytest.approx([0.055, 0.055])
    assert connection_latched(out, '/ground_truth/landmarks')
    ref = [pose2(m) for _, m in bag['/ground_truth/odom']]
    assert ref[0][:2] == pytest.approx((0.03, 0.0), abs=1e-9)
    assert bag['/ground_truth/odom'][0][1].child_frame_id == 'laser_truth'


def test_arena_frame_option(tmp_path):
    d = write_logs(tmp_path / 'logs')
    out = str(tmp_path / 'a.bag')
    assert lego.main([d, '-o', out, '-q', '--truth-frame', 'arena']) == 0
    bag = read_bag(out)
    assert pose2(bag['/ground_truth/odom'][0][1])[:2] == pytest.approx((1.850, 1.897))
    assert bag['/ground_truth/landmarks'][0][1].trunks[0].center.x == pytest.approx(1.291)


@pytest.mark.parametrize('which, text, pattern', [
    ('scans', 'S 150 660 1 2 3\r\n', 'robot4_scan.txt:1: expected S ts n and 660 ranges (663 fields), got 6 fields'),
    ('motors', 'M 100 0 0 3000 0 0 0\r\nM 200 1x 0 3000 0 0 0\r\n',
     "robot4_motors.txt:2: expected integers as the time stamp and the tick counts (fields 1, 2, 6), got '1x'"),
    ('motors', '', 'robot4_motors.txt: expected motor records "M ts left ... right ...", got an empty file'),
    ('reference', 'P 120 1850\r\n', 'robot4_reference.txt:1: expected P ts x y (4 fields), got 3 fields'),
    ('landmarks', 'L R 1 2 3\r\n', "robot_arena_landmarks.txt:1: expected landmark type 'C' (cylinder), got 'R'"),
    ('scans', 'X 1 2\r\n', "robot4_scan.txt:1: expected a line starting with 'S', got 'X'"),
])
def test_malformed_logs(tmp_path, capsys, which, text, pattern):
    d = write_logs(tmp_path / 'logs', **{which: text})
    out = tmp_path / 'bad.bag'
    code, _, err = run_main(lego.main, [d, '-o', str(out), '-q'], capsys)
    assert code == 1 and pattern in err, err
    assert not [f for f in os.listdir(str(tmp_path)) if f.endswith('.bag')]


def test_real_logs(tmp_path):
    d = os.path.dirname(data_path('brenner_lego', 'robot4_motors.txt'))
    out = str(tmp_path / 'robot4.bag')
    summary = cc.convert_to_bag(lego.convert, lego.build_parser().parse_args([d, '-o', out]))
    # 278 records of each; 61 motor records repeat the stamp before them (merged)
    assert summary.counts['/odom'] == 217 and summary.counts['/tf'] == 217
    assert summary.counts['/scan'] == 278 and summary.counts['/ground_truth/odom'] == 278
    assert summary.counts['/ground_truth/landmarks'] == 1 and summary.counts['/ground_truth/path'] == 1
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    assert bag['/odom'][0][0] == pytest.approx(0.204 + lego.SCAN_LATENCY)
    assert bag['/odom'][-1][0] == pytest.approx(55.685 + lego.SCAN_LATENCY)
    assert pose2(bag['/odom'][0][1]) == pytest.approx((0.0, 0.0, 0.0))
    scans = [m for _, m in bag['/scan']]
    assert scans[0].ranges[:3] == pytest.approx([0.189, 0.186, 0.192])  # metres
    r = np.array([s.ranges for s in scans])
    assert np.sum(np.isnan(r)) == 41 and np.nanmax(r) == pytest.approx(2.483)
    assert frames_of(bag, '/scan') == {'laser'} and frames_of(bag, '/ground_truth/odom') == {'map'}
    lm = bag['/ground_truth/landmarks'][0][1]
    assert len(lm.trunks) == 6 and all(t.radius == pytest.approx(0.055) for t in lm.trunks)
    # the reference starts at the scanner, 30 mm ahead of the robot's start pose, and ends at (593, 1766) mm
    ref = [pose2(m) for _, m in bag['/ground_truth/odom']]
    assert ref[0][:2] == pytest.approx((0.03, 0.0), abs=1e-9)
    ex, ey = lego.arena_to_start(0.593, 1.766)
    assert ref[-1][:2] == pytest.approx((ex, ey))
    # the odometry follows the reference early on (it drifts later)
    odom = [(t, pose2(m)) for t, m in bag['/odom']]
    t_ref = bag['/ground_truth/odom'][27][0]
    x, y, th = min(odom, key=lambda o: abs(o[0] - t_ref))[1]
    gx, gy, _ = ref[27]
    assert math.hypot(x + 0.03 * math.cos(th) - gx, y + 0.03 * math.sin(th) - gy) < 0.1
