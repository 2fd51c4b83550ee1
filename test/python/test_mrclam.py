"""mrclam_to_bag: commanded velocities integrated as logged, barcodes to subjects, robots dropped, the Vicon truth in
the start frame, stamps printed with too few digits; both layouts of the files; malformed files; the real data."""
import gzip
import math
import os
import re

import numpy as np
import pytest

from bagcheck import assert_stamps_monotonic, connection_latched, data_path, frames_of, pose2, read_bag, run_main
from rbpf_slam import convert_common as cc
from rbpf_slam import evaluate as ev
from rbpf_slam import mrclam

pytest.importorskip('rosbag')
from rbpf_slam.msg import Trunk  # noqa: E402


# --- the model -------------------------------------------------------------------------------------


def test_commanded_velocities_integrated_as_logged():
    t = np.arange(0.0, 10.0 + 1e-9, 0.02)
    x, y, th, v, w = mrclam.commanded_odometry(t, np.full(len(t), 0.1), np.zeros(len(t)))
    assert (x[0], y[0], th[0]) == (0.0, 0.0, 0.0)
    assert (x[-1], y[-1], th[-1]) == pytest.approx((1.0, 0.0, 0.0), abs=1e-9)
    # each message carries the command over the step ending at its stamp
    _, _, _, v, w = mrclam.commanded_odometry([0.0, 1.0, 3.0], [0.1, 0.2, 0.3], [0.0, 0.5, 0.0])
    assert list(v) == [0.0, 0.1, 0.2] and list(w) == [0.0, 0.0, 0.5]
    # a constant (v, w) drives a circle of radius v / w, closed after 2 pi / w
    w0, v0 = 0.5, 0.2
    t = np.linspace(0.0, 2 * math.pi / w0, 101)
    x, y, th, _, _ = mrclam.commanded_odometry(t, np.full(len(t), v0), np.full(len(t), w0))
    assert (x[-1], y[-1]) == pytest.approx((0.0, 0.0), abs=1e-9)
    assert (x[25], y[25]) == pytest.approx((v0 / w0, v0 / w0), abs=1e-9)


def test_stamps_printed_with_five_significant_digits_are_spread_out():
    true = 990.0 + 0.02 * np.arange(1000)  # 990 .. 1009.98 s at 50 Hz
    printed = np.array([float('%.5g' % t) for t in true])
    assert np.sum(np.diff(printed) == 0) > 300
    spread, shared, moved = cc.spread_equal_stamps(printed)
    assert np.all(np.diff(spread) > 0) and shared > 300 and moved < 0.0501
    assert np.max(np.abs(spread - true)) < 0.035 < np.max(np.abs(printed - true))
    assert spread[-2:] == pytest.approx(true[-2:])  # a run cut by the end goes on at the runs' rate
    distinct = np.array([0.0, 0.5, 0.7])
    assert list(cc.spread_equal_stamps(distinct)[0]) == list(distinct)
    with pytest.raises(cc.TooFewStamps):
        cc.spread_equal_stamps([3.0, 3.0, 3.0])


def test_frames():
    x, y, th = mrclam.to_frame((1.0, 2.0, math.pi / 2), [2.0, 1.0], [1.0, 3.0], [math.pi / 2, 0.0])
    assert list(zip(x, y)) == [pytest.approx((-1.0, -1.0)), pytest.approx((1.0, 0.0))]
    assert th == pytest.approx([0.0, -math.pi / 2])


# --- a tiny data set ---------------------------------------------------------------------------------

BARCODES = ('# UTIAS Multi-Robot Cooperative Localization and Mapping Dataset\n# Subject #    Barcode #\n'
            '  1 \t   5 \n  2 \t  14 \n  3 \t  41 \n  4 \t  32 \n  5 \t  23 \n  6 \t  72 \n  7 \t  27 \n  8 \t  54 \n')
LANDMARKS = '  6 \t 2.0 \t 1.0 \t 0.001 \t 0.002 \n  7 \t 0.0 \t -3.0 \t 0.001 \t 0.001 \n  8 \t 1 \t 1 \t 0 \t 0 \n'
ODOMETRY = ''.join('%g %g 0\n' % (0.5 * k, 0.2) for k in range(5))  # 0 .. 2 s at 0.2 m/s
GROUNDTRUTH = '0 1 2 1.5707963\n1 1 2.2 1.5707963\n2 1 2.4 1.5707963\n'
MEASUREMENT = ('0.5 72 1.0 0.1\n'
               '0.5 14 2.0 0.0\n'
               '1 5 1.0 0.0\n'
               '1.5 43 3.0 0.2\n'
               '1.5 27 6.0 -0.7\n'
               '5 72 1.0 0.0\n')


def write_set(d, robot=1, gz=True, odometry=ODOMETRY, measurement=MEASUREMENT, groundtruth=GROUNDTRUTH,
              barcodes=BARCODES, landmarks=LANDMARKS):
    d.mkdir(exist_ok=True)
    files = {'Robot%d_Odometry.dat' % robot: odometry, 'Robot%d_Measurement.dat' % robot: measurement,
             'Robot%d_Groundtruth.dat' % robot: groundtruth, 'Barcodes.dat': barcodes,
             'Landmark_Groundtruth.dat': landmarks}
    for name, text in files.items():
        if text is None:
            continue
        if gz:
            (d / (name + '.gz')).write_bytes(gzip.compress(text.encode()))
        else:
            (d / name).write_text(text)
    return str(d)


def test_tiny_set(tmp_path, capsys):
    d = write_set(tmp_path / 'm')
    out = str(tmp_path / 'm.bag')
    code, stdout, _ = run_main(mrclam.main, [d, '--robot', '1', '-o', out, '-q'], capsys)
    assert code == 0
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    odom = [(t, pose2(msg)) for t, msg in bag['/odom']]
    # The files' clock starts at 0, which ROS takes as no time: shifted by 1 s.
    assert [t for t, _ in odom] == pytest.approx([1.0, 1.5, 2.0, 2.5, 3.0])
    assert odom[0][1] == (0.0, 0.0, 0.0) and odom[-1][1] == pytest.approx((0.4, 0.0, 0.0))
    assert bag['/odom'][2][1].twist.twist.linear.x == pytest.approx(0.2) and len(bag['/tf']) == 5
    # readings: one array per time, robots and unknown barcodes dropped, ids from Barcodes.dat
    arrays = [(t, msg) for t, msg in bag['/landmarks']]
    assert [t for t, _ in arrays] == pytest.approx([1.5, 2.0, 2.5])
    assert [[tr.id for tr in a.trunks] for _, a in arrays] == [[6], [], [7]]
    tr = arrays[0][1].trunks[0]
    assert (tr.center.x, tr.center.y) == pytest.approx((math.cos(0.1), math.sin(0.1)))
    assert (tr.range, tr.bearing, tr.radius, tr.method) == (pytest.approx(1.0), pytest.approx(0.1), 0.0,
                                                             Trunk.METHOD_GIVEN)
    cov = np.array(tr.covariance).reshape(2, 2)
    assert np.trace(cov) == pytest.approx(0.15 ** 2 + 0.03 ** 2)
    a = arrays[0][1]
    assert a.header.frame_id == 'base_link'
    assert (a.min_range, a.max_range, a.fov_min, a.fov_max, a.detection_probability) == pytest.approx(
        (0.0, 5.0, -math.radians(30), math.radians(30), 0.0))
    assert re.search(r' 2  readings of robots \(subjects 1-5: not landmarks\)', stdout)
    assert re.search(r' 1  readings of barcodes Barcodes.dat does not list', stdout)
    assert re.search(r' 1  readings timed outside the odometry', stdout)
    assert '1 readings lie beyond 5.0 m, 1 beyond +-30 deg' in stdout
    # the truth in the start frame: the robot's first Vicon pose is the origin
    ref = [pose2(msg) for _, msg in bag['/ground_truth/odom']]
    assert ref[0] == pytest.approx((0.0, 0.0, 0.0), abs=1e-7) and ref[-1] == pytest.approx((0.4, 0.0, 0.0), abs=1e-6)
    assert bag['/ground_truth/odom'][0][1].child_frame_id == 'base_link_truth'
    truth = bag['/ground_truth/landmarks'][0][1]
    assert [t.id for t in truth.trunks] == [6, 7, 8] and truth.header.frame_id == 'map'
    assert (truth.trunks[0].center.x, truth.trunks[0].center.y) == pytest.approx((-1.0, -1.0), abs=1e-6)
    assert truth.trunks[0].covariance == pytest.approx([1e-6, 0.0, 0.0, 4e-6])
    assert connection_latched(out, '/ground_truth/landmarks') and connection_latched(out, '/ground_truth/path')
    assert frames_of(bag, '/ground_truth/odom') == {'map'}


def test_room_frame_no_ids_and_limit(tmp_path):
    d = write_set(tmp_path / 'm', gz=False)
    out = str(tmp_path / 'r.bag')
    assert mrclam.main([d, '--robot', '1', '-o', out, '-q', '--truth-frame', 'room', '--no-ids', '--limit', '3']) == 0
    bag = read_bag(out)
    assert [t for t, _ in bag['/odom']] == pytest.approx([1.0, 1.5, 2.0])
    assert [[tr.id for tr in a.trunks] for _, a in bag['/landmarks']] == [[-1], []]
    assert pose2(bag['/ground_truth/odom'][0][1]) == pytest.approx((1.0, 2.0, math.pi / 2))
    lm = bag['/ground_truth/landmarks'][0][1].trunks[0]
    assert (lm.center.x, lm.center.y) == (2.0, 1.0)


def test_original_release_layout(tmp_path, capsys):
    """Unix-epoch stamps, '#' headers, plain files, odometry at its own rate, no ground-truth files."""
    t0 = 1248272272.841
    header = '# Time [s]    forward velocity [m/s]    angular velocity[rad/s]\n'
    odometry = header + ''.join('%.3f %g %g\n' % (t0 + dt, 0.1, 0.0) for dt in (0.0, 0.013, 0.041, 0.07, 1.07))
    measurement = '# Time [s]    Subject #    range [m]    bearing [rad]\n%.3f 72 1.5 0.2\n' % (t0 + 0.5)
    d = write_set(tmp_path / 'o', robot=3, gz=False, odometry=odometry, measurement=measurement, groundtruth=None,
                  landmarks=None)
    out = str(tmp_path / 'o.bag')
    code, stdout, _ = run_main(mrclam.main, [d, '--robot', '3', '-o', out, '-q'], capsys)
    assert code == 0, stdout
    bag = read_bag(out)
    assert [t for t, _ in bag['/odom']] == pytest.approx([t0, t0 + 0.013, t0 + 0.041, t0 + 0.07, t0 + 1.07])
    assert pose2(bag['/odom'][-1][1])[0] == pytest.approx(0.107)
    assert [tr.id for tr in bag['/landmarks'][0][1].trunks] == [6]
    assert not [t for t in bag if t.startswith('/ground_truth')]
    assert 'no Robot3_Groundtruth.dat' in stdout and 'no Landmark_Groundtruth.dat' in stdout


@pytest.mark.parametrize('change, expected', [
    ({'odometry': '0 0.1 0\n0.5 0.1\n'}, 'Robot1_Odometry.dat.gz:2: expected time v w (3 fields), got 2 fields'),
    ({'odometry': '0 0.1 0\n0.5 0.1 0\n0.4 0.1 0\n'},
     'Robot1_Odometry.dat.gz:3: expected times in non-decreasing order, got 0.4 after 0.5 on line 2'),
    ({'odometry': '1 0.1 0\n1 0.1 0\n'},
     'Robot1_Odometry.dat.gz: expected stamps that advance, got all 2 stamps equal'),
    ({'odometry': '0 0.1 0\n0.5 1e308 0\n1 0.1 0\n'},
     'Robot1_Odometry.dat.gz:2: expected a forward velocity within +-2 m/s, got 1e+308'),
    ({'odometry': '0 0.1 0\n0.5 0.1 -40\n1 0.1 0\n'},
     'Robot1_Odometry.dat.gz:2: expected an angular velocity within +-6.283 rad/s, got -40'),
    ({'measurement': '0.5 72.5 1.0 0.1\n'},
     'Robot1_Measurement.dat.gz:1: expected a whole number as the barcode, got 72.5'),
    ({'measurement': '1248272272.8 72 1.0 0.1\n'},
     'Robot1_Measurement.dat.gz:1: expected stamps on the clock of Robot1_Odometry.dat.gz (0.000 .. 2.000 s), got '
     '1248272272.800'),
    ({'barcodes': BARCODES + '  9 \t  14 \n'},
     'Barcodes.dat.gz:11: expected each subject and barcode listed once, got barcode 14 again (first on line 4)'),
    ({'landmarks': '  3 \t 2.0 \t 1.0 \t 0.001 \t 0.002 \n'},
     'Landmark_Groundtruth.dat.gz:1: expected a landmark subject (a whole number from 6; 1-5 are the robots), got 3'),
    ({'groundtruth': '0 1 2 0\n1 1 2.2\n'},
     'Robot1_Groundtruth.dat.gz:2: expected time x y theta (4 fields), got 3 fields'),
    ({'barcodes': None}, 'Barcodes.dat: no such file or directory'),
    ({'measurement': ''}, 'Robot1_Measurement.dat.gz: expected lines of time barcode range bearing, got an empty file'),
])
def test_malformed_files(tmp_path, capsys, change, expected):
    d = write_set(tmp_path / 'm', **change)
    out = tmp_path / 'out'
    out.mkdir()
    code, _, err = run_main(mrclam.main, [d, '--robot', '1', '-o', str(out / 'x.bag'), '-q'], capsys)
    assert code == 1 and expected in err and len(err.strip().splitlines()) == 1, err
    assert err.startswith('mrclam_to_bag: ')
    assert os.listdir(str(out)) == []


def test_skip_bad(tmp_path, capsys):
    d = write_set(tmp_path / 'm', measurement=MEASUREMENT + '1.7 x 1 0\n')
    out = str(tmp_path / 's.bag')
    code, stdout, _ = run_main(mrclam.main, [d, '--robot', '1', '-o', out, '-q', '--skip-bad'], capsys)
    assert code == 0 and 'malformed lines skipped (--skip-bad): 1' in stdout
    assert len(read_bag(out)['/landmarks']) == 3


# --- the real data set ------------------------------------------------------------------------------


def test_real_data_first_100_s(tmp_path):
    d = os.path.dirname(data_path('mrclam', 'Robot1_Odometry.dat.gz'))
    out = str(tmp_path / 'mr1.bag')
    summary = cc.convert_to_bag(mrclam.convert, mrclam.build_parser().parse_args(
        [d, '--robot', '1', '-o', out, '--limit', '5000']))
    assert summary.counts['/odom'] == 5000 and summary.counts['/ground_truth/landmarks'] == 1
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    assert bag['/odom'][-1][0] == pytest.approx(100.98)
    arrays = bag['/landmarks']
    assert arrays[0][0] == pytest.approx(13.72) and [t.id for t in arrays[0][1].trunks] == [16]  # barcode 90
    ids = set(t.id for _, a in arrays for t in a.trunks)
    assert ids and ids <= set(range(6, 21))
    # a reading seen from the Vicon pose lands near its landmark's truth
    truth = {t.id: (t.center.x, t.center.y) for t in bag['/ground_truth/landmarks'][0][1].trunks}
    assert sorted(truth) == list(range(6, 21))
    ref_t = np.array([t for t, _ in bag['/ground_truth/odom']])
    ref = np.array([pose2(m) for _, m in bag['/ground_truth/odom']])
    errors = []
    for t, a in arrays:
        k = int(np.argmin(np.abs(ref_t - t)))
        x, y, th = ref[k]
        for tr in a.trunks:
            wx = x + math.cos(th) * tr.center.x - math.sin(th) * tr.center.y
            wy = y + math.sin(th) * tr.center.x + math.cos(th) * tr.center.y
            errors.append(math.hypot(wx - truth[tr.id][0], wy - truth[tr.id][1]))
    assert len(errors) > 100 and np.median(errors) < 0.25


def test_real_commanded_odometry_drifts_a_few_metres():
    d = os.path.dirname(data_path('mrclam', 'Robot1_Odometry.dat.gz'))
    t, v, w = mrclam.read_odometry(os.path.join(d, 'Robot1_Odometry.dat.gz'))
    tg, gx, gy, _ = mrclam.read_groundtruth(os.path.join(d, 'Robot1_Groundtruth.dat.gz'))
    t, shared, moved = cc.spread_equal_stamps(t)
    tg = cc.spread_equal_stamps(tg)[0]
    assert len(t) == 75000 and shared == 25000 and moved < 0.06
    x, y, _, _, _ = mrclam.commanded_odometry(t, v, w)
    odo = np.column_stack([np.interp(tg, t, x), np.interp(tg, t, y)])
    assert ev.aligned_rmse(odo, np.column_stack([gx, gy])) == pytest.approx(2.84, abs=0.1)
