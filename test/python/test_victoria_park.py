"""victoria_park_to_bag: the bicycle model about the rear axle, no returns as +Inf, the GPS's axes, the tree
detections as TrunkArray; the zip as distributed or its extracted files; malformed files; the real data set."""
import gzip
import math
import os
import signal
import subprocess
import sys
import time
import zipfile

import numpy as np
import pytest

from bagcheck import (ROOT, assert_stamps_monotonic, connection_latched, data_path, frames_of, pose2, read_bag,
                      run_main, static_transforms)
from rbpf_slam import convert_common as cc
from rbpf_slam import evaluate as ev
from rbpf_slam import victoria_park as vp

pytest.importorskip('rosbag')
from rbpf_slam.msg import Trunk  # noqa: E402

L, H = vp.WHEELBASE, vp.ENCODER_LEFT


# --- the model -------------------------------------------------------------------------------------


def test_the_constants_are_the_data_sets():
    assert (vp.WHEELBASE, vp.ENCODER_LEFT, vp.LASER_AHEAD_OF_FRONT_AXLE, vp.LASER_LEFT) == (2.83, 0.76, 0.95, 0.5)
    assert vp.LASER_MOUNT == pytest.approx((3.78, 0.5))


def test_a_straight_drive_at_constant_speed():
    t = np.arange(0.0, 10.0 + 1e-9, 0.025)
    x, y, th, v, w = vp.bicycle_odometry(t, np.full(len(t), 2.0), np.zeros(len(t)))
    assert (x[0], y[0], th[0]) == (0.0, 0.0, 0.0)
    assert (x[-1], y[-1], th[-1]) == pytest.approx((20.0, 0.0, 0.0), abs=1e-9)
    assert v[-1] == pytest.approx(2.0) and w[-1] == 0.0 and v[0] == 0.0


def test_a_constant_steering_angle_turns_at_the_bicycle_models_rate():
    steer, speed, duration = 0.2, 3.0, 8.0
    t = np.arange(0.0, duration + 1e-9, 0.025)
    x, y, th, v, w = vp.bicycle_odometry(t, np.full(len(t), speed), np.full(len(t), steer))
    # the encoder wheel runs on the inside of a left turn: the axle's centre is faster
    vc = speed / (1.0 - math.tan(steer) * H / L)
    assert vc > speed and v[-1] == pytest.approx(vc)
    rate = vc * math.tan(steer) / L
    assert w[-1] == pytest.approx(rate)
    assert th[-1] == pytest.approx(rate * duration)
    # on a circle of radius L / tan(steer) about a point to the left of the start
    r = L / math.tan(steer)
    assert (x[-1], y[-1]) == pytest.approx((r * math.sin(rate * duration), r * (1 - math.cos(rate * duration))),
                                           abs=1e-9)
    # right turn: the mirror image, with the encoder wheel outside (slower centre)
    x2, y2, th2, v2, _ = vp.bicycle_odometry(t, np.full(len(t), speed), np.full(len(t), -steer))
    assert v2[-1] == pytest.approx(speed / (1.0 + math.tan(steer) * H / L)) and th2[-1] < 0 and y2[-1] < 0


def test_the_top_cluster_of_readings_is_no_return():
    scans = np.array([[81.91] * 6 + [81.87] * 3 + [81.83, 81.7, 20.0, 0.0],
                      [81.91] * 4 + [5.0] * 9])
    threshold, n = vp.no_return_threshold(scans)
    assert threshold == pytest.approx(81.81) and n == 14
    r = vp.scan_to_rep117(scans[0], threshold)
    assert np.isinf(r[:10]).all() and r[10] == pytest.approx(81.7) and r[11] == 20.0 and math.isnan(r[12])
    # fewer than 10 readings up there: every reading is a return
    assert vp.no_return_threshold(np.array([81.91] * 9 + [3.0]))[0] is None


# --- a tiny release ---------------------------------------------------------------------------------


def laser_stream(stamps, ranges=None):
    """LASER.txt as distributed: one tab-separated stream, no line end."""
    out = []
    for i, t in enumerate(stamps):
        r = ranges[i] if ranges is not None else [5.0 + 0.01 * k for k in range(vp.BEAMS)]
        out.append('%.3f\t%s' % (t, '\t'.join('%.2f' % v for v in r)))
    return '\t'.join(out)


def scan_with_no_returns():
    r = [81.91] * vp.BEAMS
    r[0], r[180], r[1], r[2] = 10.0, 20.0, 81.87, 81.83
    return r


LASER = laser_stream([1.0, 1.2, 1.4], [scan_with_no_returns()] + [scan_with_no_returns()] * 2 + [None] * 8)
DRS = ''.join('%.3f\t %.3f\t%.4f\r\n' % (1.0 + 0.025 * k, 2.0, 0.0) for k in range(21))  # 1.0 .. 1.5 s, 2 m/s
GPS = '0.000\t  0.00\t  0.00\r\n1.001\t  1.00\t  -2.00\r\n1.401\t  1.50\t  -3.00\r\n'
DETECTIONS = ('     1.000   10.00000    1.57080    0.40000\n'
              '     1.000   20.00000    0.00000    0.30000\n'
              '     1.400    5.00000    3.14159    0.20000\n'
              '     9.000    5.00000    1.00000    0.20000\n')


def write_release(d, laser=LASER, drs=DRS, gps=GPS, detections=DETECTIONS, layout='zip'):
    d.mkdir(exist_ok=True)
    files = {'LASER.txt': laser, 'DRS.txt': drs, 'GPS.txt': gps}
    if layout == 'zip':
        with zipfile.ZipFile(str(d / vp.ARCHIVE), 'w', zipfile.ZIP_DEFLATED) as z:
            for name, text in files.items():
                if text is not None:
                    z.writestr(name, text)
    else:
        for name, text in files.items():
            if text is not None:
                (d / name).write_text(text)
    if detections is not None:
        (d / 'published_measurements.dat.gz').write_bytes(gzip.compress(detections.encode()))
    return str(d)


def test_tiny_zip(tmp_path, capsys):
    d = write_release(tmp_path / 'vp')
    out = str(tmp_path / 'vp.bag')
    code, stdout, _ = run_main(vp.main, [d, '-o', out, '-q', '--detections'], capsys)
    assert code == 0
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    # scans: 361 beams from -pi/2 at 0.5 deg in the laser frame; the top cluster +Inf, range_max below it
    scans = [msg for _, msg in bag['/scan']]
    # The data's clock (here from 1.0 s) shifted by 1 s: ROS time 0 is no time, and the set's GPS starts at 0.
    assert [t for t, _ in bag['/scan']] == pytest.approx([2.0, 2.2, 2.4])
    s = scans[0]
    assert len(s.ranges) == 361 and s.header.frame_id == 'laser'
    assert s.angle_min == pytest.approx(-math.pi / 2) and s.angle_increment == pytest.approx(math.radians(0.5))
    assert s.angle_max == pytest.approx(math.pi / 2)
    assert s.ranges[0] == pytest.approx(10.0) and s.ranges[180] == pytest.approx(20.0)
    assert all(math.isinf(v) for v in s.ranges[1:180]) and s.range_max == pytest.approx(81.80)
    # odometry: 2 m/s straight for 0.5 s; the laser 3.78 m ahead of the rear axle, 0.5 m left
    odom = [pose2(msg) for _, msg in bag['/odom']]
    assert len(odom) == 21 and odom[0] == (0.0, 0.0, 0.0) and odom[-1] == pytest.approx((1.0, 0.0, 0.0))
    assert bag['/odom'][-1][1].twist.twist.linear.x == pytest.approx(2.0)
    assert len(bag['/tf']) == 21
    mount = static_transforms(bag)[('base_link', 'laser')]
    assert (mount.transform.translation.x, mount.transform.translation.y) == pytest.approx((3.78, 0.5))
    # GPS: time north east -> x east, y north, positions only
    ref = [(t, pose2(msg)) for t, msg in bag['/ground_truth/odom']]
    assert [t for t, _ in ref] == pytest.approx([1.0, 2.001, 2.401])
    assert ref[1][1] == pytest.approx((-2.0, 1.0, 0.0))
    q = bag['/ground_truth/odom'][1][1].pose.pose.orientation
    assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
    assert frames_of(bag, '/ground_truth/odom') == {'map'} and bag['/ground_truth/odom'][0][1].child_frame_id == 'gps'
    assert connection_latched(out, '/ground_truth/path') and len(bag['/ground_truth/path'][0][1].poses) == 3
    # detections: one array per scan (empty where none), in the laser frame: bearing - pi/2
    arrays = [(t, msg) for t, msg in bag['/landmarks']]
    assert [t for t, _ in arrays] == pytest.approx([2.0, 2.2, 2.4])
    assert [len(a.trunks) for _, a in arrays] == [2, 0, 1]
    ahead, right = arrays[0][1].trunks
    assert (ahead.center.x, ahead.center.y) == pytest.approx((10.0, 0.0), abs=1e-4)
    assert (right.center.x, right.center.y) == pytest.approx((0.0, -20.0), abs=1e-9)
    assert ahead.bearing == pytest.approx(0.0, abs=1e-5) and right.bearing == pytest.approx(-math.pi / 2)
    assert (ahead.radius, ahead.method, ahead.id) == (pytest.approx(0.2), Trunk.METHOD_GIVEN, -1)
    assert ahead.radius_variance == pytest.approx(0.002 / 4)
    cov = np.array(ahead.covariance).reshape(2, 2)  # ahead: range noise along x, bearing noise across
    assert cov[0, 0] == pytest.approx(0.025) and cov[1, 1] == pytest.approx(100 * 0.000025, rel=1e-4)
    a = arrays[0][1]
    assert (a.min_range, a.max_range, a.detection_probability) == pytest.approx((1.45, 70.0, 0.9))
    assert (a.fov_min, a.fov_max) == pytest.approx((math.radians(6.3025 - 90), math.radians(87.0)))
    assert arrays[0][1].header.frame_id == 'laser'
    assert 'detections timed outside the laser log (1 times)' in stdout
    assert '81.91 m: ' in stdout and 'range_max 81.80 m' in stdout


@pytest.mark.parametrize('layout', ['folder', 'zip path'])
def test_the_extracted_files_and_the_zip_itself(tmp_path, layout):
    zipped = write_release(tmp_path / 'z')
    assert vp.main([zipped, '-o', str(tmp_path / 'z.bag'), '-q']) == 0
    if layout == 'folder':
        source = write_release(tmp_path / 'f', layout='folder')
    else:
        source = os.path.join(zipped, vp.ARCHIVE)
    assert vp.main([source, '-o', str(tmp_path / 'f.bag'), '-q']) == 0
    a, b = read_bag(str(tmp_path / 'z.bag')), read_bag(str(tmp_path / 'f.bag'))
    assert sorted(a) == sorted(b)
    for topic in ('/odom', '/scan', '/ground_truth/odom'):
        assert [str(m) for _, m in a[topic]] == [str(m) for _, m in b[topic]]


def test_a_scan_a_line_and_gzip(tmp_path):
    d = tmp_path / 'f'
    write_release(d, layout='folder')
    text = '\n'.join(laser_stream([t]) for t in (1.0, 1.2, 1.4)) + '\n'
    (d / 'LASER.txt').write_text(text)
    (d / 'DRS.txt').unlink()
    (d / 'DRS.txt.gz').write_bytes(gzip.compress(DRS.encode()))
    out = str(tmp_path / 'l.bag')
    assert vp.main([str(d), '-o', out, '-q']) == 0
    bag = read_bag(out)
    assert len(bag['/scan']) == 3 and len(bag['/odom']) == 21 and '/landmarks' not in bag


def test_limit_time_offset_and_no_gps(tmp_path):
    d = write_release(tmp_path / 'vp')
    out = str(tmp_path / 'l.bag')
    assert vp.main([d, '-o', out, '-q', '--limit', '2', '--detections', '--time-offset', '100', '--no-gps']) == 0
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    assert [t for t, _ in bag['/scan']] == pytest.approx([101.0, 101.2])
    # the odometry up to the first line at or after the last scan
    assert [t for t, _ in bag['/odom']][-1] == pytest.approx(101.2) and len(bag['/odom']) == 9
    assert [len(m.trunks) for _, m in bag['/landmarks']] == [2, 0]
    assert '/ground_truth/odom' not in bag


def test_skip_bad(tmp_path, capsys):
    drs = DRS.replace('1.050\t 2.000\t0.0000', '1.050\t 2.000')
    d = write_release(tmp_path / 'vp', drs=drs)
    out = str(tmp_path / 's.bag')
    code, stdout, _ = run_main(vp.main, [d, '-o', out, '-q', '--skip-bad'], capsys)
    assert code == 0 and 'malformed lines skipped (--skip-bad): 1' in stdout
    assert len(read_bag(out)['/odom']) == 20


def _cut(text, drop):
    return text[:-drop]


@pytest.mark.parametrize('change, expected', [
    ({'drs': DRS.replace('1.050\t 2.000\t0.0000', '1.050\t 2.000')},
     'victoria_park_ascii.zip/DRS.txt:3: expected time speed steering (3 fields), got 2 fields'),
    ({'drs': DRS.replace('1.050\t 2.000', '1.050\t nan')},
     "DRS.txt:3: expected numbers as time speed steering, got 'nan' (not a finite number)"),
    ({'drs': DRS.replace('1.050\t', '1.000\t')},
     'DRS.txt:3: expected times in increasing order, got 1.000 after 1.025 on line 2'),
    ({'drs': DRS.replace('1.050\t 2.000\t0.0000', '1.050\t 2.000\t1.5000')},
     'DRS.txt:3: expected a steering angle within +-1 rad, got 1.5'),
    ({'drs': DRS.replace('1.050\t 2.000', '1.050\t 1e308')},
     'DRS.txt:3: expected a speed within +-30 m/s, got 1e+308'),
    ({'gps': GPS + '1.2 3\r\n'}, 'GPS.txt:4: expected time north east (3 fields), got 2 fields'),
    ({'laser': _cut(LASER, 300)}, 'LASER.txt:1: expected a time and 361 ranges (362 numbers) in scan 3, got '),
    ({'laser': laser_stream([100.0]) + '\t' + laser_stream([100.2])[8:] + '\t' + laser_stream([100.4])},
     "LASER.txt:1: expected the time of scan 2 after 100.000 s (a time and 361 ranges a scan), got '5.00'"),
    ({'laser': laser_stream([1.0, 1.2]).replace('\t5.03\t', '\tx\t', 1)},
     "LASER.txt:1: expected numbers as the 361 ranges of scan 1, got 'x'"),
    ({'laser': ''}, 'LASER.txt: expected scans of a time and 361 ranges, got an empty file'),
    ({'drs': '%d 1 0\n' % 1300000000}, 'DRS.txt: expected stamps on the clock of LASER.txt (1.000 .. 1.400 s), got '
                                       '1300000000.000'),
    ({'gps': None}, 'victoria_park_ascii.zip: expected GPS.txt in the archive, got members LASER.txt, DRS.txt'),
    ({'detections': '1.0 2.0 0.5\n'}, 'published_measurements.dat.gz:1: expected time range bearing diameter '
                                      '(4 fields), got 3 fields'),
])
def test_malformed_files(tmp_path, capsys, change, expected):
    d = write_release(tmp_path / 'vp', **change)
    out = tmp_path / 'out'
    out.mkdir()
    code, _, err = run_main(vp.main, [d, '-o', str(out / 'x.bag'), '-q', '--detections'], capsys)
    assert code == 1 and expected in err and len(err.strip().splitlines()) == 1, err
    assert err.startswith('victoria_park_to_bag: ')
    assert os.listdir(str(out)) == []


def test_a_damaged_archive(tmp_path, capsys):
    d = write_release(tmp_path / 'vp')
    archive = tmp_path / 'vp' / vp.ARCHIVE
    data = archive.read_bytes()
    with zipfile.ZipFile(str(archive)) as z:
        info = z.getinfo('LASER.txt')
    archive.write_bytes(data[:len(data) // 2])
    code, _, err = run_main(vp.main, [d, '-o', str(tmp_path / 'x.bag'), '-q'], capsys)
    assert code == 1 and '%s: expected a zip archive (the ASCII release), got a damaged' % archive in err, err
    # a member whose compressed data is damaged (the archive's directory intact)
    start = info.header_offset + 30 + len(info.filename) + len(info.extra) + 10
    broken = bytearray(data)
    broken[start:start + 20] = bytes(20)
    archive.write_bytes(bytes(broken))
    code, _, err = run_main(vp.main, [d, '-o', str(tmp_path / 'x.bag'), '-q'], capsys)
    assert code == 1 and 'LASER.txt:1: expected more data (the compressed file is cut short or damaged)' in err, err
    assert not (tmp_path / 'x.bag').exists()


def test_sigterm_while_writing_leaves_no_file(tmp_path):
    """A long drive (an hour of DRS lines): SIGTERM in the middle of writing, exit 143, nothing left behind."""
    drs = ''.join('%.3f\t 2.000\t0.0100\n' % (1.0 + 0.025 * k) for k in range(144000))
    d = write_release(tmp_path / 'vp', drs=drs, laser=laser_stream([1.0, 3600.0]), layout='folder')
    out = tmp_path / 'out'
    out.mkdir()
    proc = subprocess.Popen([sys.executable, os.path.join(ROOT, 'scripts', 'victoria_park_to_bag'), d, '-o',
                             str(out / 'x.bag'), '-q'], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            universal_newlines=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            partial = [n for n in os.listdir(str(out)) if '.partial' in n]
            if partial and os.path.getsize(str(out / partial[0])) > 256 * 1024:
                break
            time.sleep(0.02)
        assert proc.poll() is None, 'the conversion ended before it could be interrupted'
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + signal.SIGTERM
    assert err == 'victoria_park_to_bag: terminated by SIGTERM, no bag written\n'
    assert os.listdir(str(out)) == []


# --- the real data set ------------------------------------------------------------------------------


def test_real_data_first_scans(tmp_path):
    d = os.path.dirname(data_path('victoria_park', vp.ARCHIVE))
    out = str(tmp_path / 'vp.bag')
    summary = cc.convert_to_bag(vp.convert, vp.build_parser().parse_args([d, '-o', out, '--limit', '300',
                                                                          '--detections']))
    assert summary.counts['/scan'] == 300 and summary.counts['/landmarks'] == 300
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    first = bag['/scan'][0][1]
    assert bag['/scan'][0][0] == pytest.approx(1.852) and bag['/scan'][-1][0] == pytest.approx(65.728)
    assert first.ranges[:3] == pytest.approx([0.83, 0.84, 0.84]) and math.isinf(first.ranges[13])
    assert first.range_max == pytest.approx(81.80)
    assert bag['/odom'][0][0] == pytest.approx(1.973) and pose2(bag['/odom'][0][1]) == (0.0, 0.0, 0.0)
    assert bag['/odom'][-1][0] >= bag['/scan'][-1][0]
    tree = bag['/landmarks'][0][1].trunks[0]  # 0.852 20.46202 0.88575 0.35404
    assert (tree.range, tree.bearing, tree.radius) == pytest.approx((20.46202, 0.88575 - math.pi / 2, 0.17702))
    assert bag['/ground_truth/odom'][0][0] == 1.0  # the set's clock starts at 0: shifted by 1 s


def test_real_dead_reckoning_against_the_gps():
    """The whole drive through the model, without writing a bag: 4 km, about 57 m RMS off the GPS after a rigid
    fit (the GPS's columns read as north, east; as x, y the path would be the mirror image, 104 m off)."""
    path = data_path('victoria_park', vp.ARCHIVE)
    release = vp.Release(path)
    try:
        name, stream = release.open(vp.DRS_FILE)
        t, speed, steering = vp.read_drs(name, stream=stream)
        name, stream = release.open(vp.GPS_FILE)
        tg, gx, gy = vp.read_gps(name, stream=stream)
    finally:
        release.close()
    assert len(t) == 61763 and len(tg) == 948
    x, y, th, _, _ = vp.bicycle_odometry(t, speed, steering)
    assert np.sum(np.hypot(np.diff(x), np.diff(y))) == pytest.approx(4030, abs=5)
    inside = (tg >= t[0]) & (tg <= t[-1])
    odo = np.column_stack([np.interp(tg[inside], t, x), np.interp(tg[inside], t, y)])
    gps = np.column_stack([gx, gy])[inside]
    assert ev.aligned_rmse(odo, gps) == pytest.approx(57.1, abs=0.5)
    assert ev.aligned_rmse(odo, gps[:, ::-1]) > 100.0


def test_a_stamp_at_ros_time_zero_is_refused(tmp_path):
    """ROS time 0 is no time (rosbag's reader refuses it as an index time): with --time-offset 0, the GPS fix at 0.0 of
    a set whose clock starts there stops the conversion, and no bag is left."""
    d = tmp_path / 'vp'
    d.mkdir()
    (d / 'LASER.txt').write_text(' '.join(['1.0'] + ['5.0'] * 361) + '\n')
    (d / 'DRS.txt').write_text('0.5 1.0 0.0\n1.5 1.0 0.0\n')
    (d / 'GPS.txt').write_text('0.0 0.0 0.0\n1.0 0.0 1.0\n')
    out = tmp_path / 'zero.bag'
    assert vp.main([str(d), '-o', str(out), '-q', '--time-offset', '0']) != 0
    assert not out.exists()
    assert vp.main([str(d), '-o', str(out), '-q']) == 0 and out.exists()
