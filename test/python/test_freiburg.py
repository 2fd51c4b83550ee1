"""freiburg_to_bag: rot1-trans-rot2 odometry, observations as TrunkArray, no true ids reach a filter; malformed
data; the real data set."""
import math
import os

import numpy as np
import pytest

from bagcheck import assert_stamps_monotonic, connection_latched, data_path, pose2, read_bag, run_main
from rbpf_slam import convert_common as cc
from rbpf_slam import freiburg

pytest.importorskip('rosbag')
from rbpf_slam.msg import Trunk  # noqa: E402

SENSOR = ('ODOMETRY 0.0 1.0 0.0\n'
          'SENSOR 3 2.0 0.5\n'
          'SENSOR 4 1.0 -0.5\n'
          'ODOMETRY 1.5707963267948966 1.0 0.0\n'
          'ODOMETRY 0.0 0.5 0.0\n'
          'SENSOR 3 -0.5 0.25\n')
WORLD = '3 2 1\n4 0 -3\n'


def write(d, sensor=SENSOR, world=WORLD):
    d.mkdir(exist_ok=True)
    (d / 'sensor_data.dat').write_text(sensor)
    if world is not None:
        (d / 'world.dat').write_text(world)
    return str(d)


def test_synthetic(tmp_path, capsys):
    out = str(tmp_path / 'f.bag')
    code, stdout, _ = run_main(freiburg.main, [write(tmp_path / 'd'), '-o', out, '-q'], capsys)
    assert code == 0
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    assert [t for t, _ in bag['/odom']] == pytest.approx([1.0, 1.1, 1.2, 1.3])
    poses = [pose2(m) for _, m in bag['/odom']]
    assert poses == [pytest.approx(p, abs=1e-12) for p in
                     [(0, 0, 0), (1, 0, 0), (1, 1, math.pi / 2), (1, 1.5, math.pi / 2)]]
    arrays = [m for _, m in bag['/landmarks']]
    assert [len(a.trunks) for a in arrays] == [0, 2, 0, 1]
    t = arrays[1].trunks[0]
    assert (t.center.x, t.center.y) == pytest.approx((2 * math.cos(0.5), 2 * math.sin(0.5)))
    assert (t.range, t.bearing, t.method, t.id) == pytest.approx((2.0, 0.5, Trunk.METHOD_GIVEN, -1))
    assert arrays[1].header.frame_id == 'base_link'
    # covariance: polar noise through the Jacobian; its trace is sigma_r^2 + r^2 sigma_b^2
    cov = np.array(t.covariance).reshape(2, 2)
    assert np.trace(cov) == pytest.approx(0.01 + 4 * 0.01) and cov[0, 1] == pytest.approx(cov[1, 0])
    # a negative range is the same point at the opposite bearing
    neg = arrays[3].trunks[0]
    assert neg.range == pytest.approx(0.5) and neg.bearing == pytest.approx(0.25 - math.pi)
    assert (neg.center.x, neg.center.y) == pytest.approx((-0.5 * math.cos(0.25), -0.5 * math.sin(0.25)))
    truth = bag['/ground_truth/landmarks'][0][1]
    assert truth.header.frame_id == 'map' and [(t.id, t.center.x, t.center.y) for t in truth.trunks] == \
        [(3, 2.0, 1.0), (4, 0.0, -3.0)]
    assert connection_latched(out, '/ground_truth/landmarks')
    assert 'ids set to -1' in stdout and '1 observation(s) with a negative range' in stdout


def test_keep_ids_and_rate(tmp_path):
    out = str(tmp_path / 'k.bag')
    assert freiburg.main([write(tmp_path / 'd'), '-o', out, '-q', '--keep-ids', '--rate', '2',
                          '--start-time', '10']) == 0
    bag = read_bag(out)
    assert [t for t, _ in bag['/odom']] == pytest.approx([10.0, 10.5, 11.0, 11.5])
    assert [t.id for t in bag['/landmarks'][1][1].trunks] == [3, 4]


def test_time_offset_moves_headers_and_bag_time(tmp_path):
    out = str(tmp_path / 'o.bag')
    assert freiburg.main([write(tmp_path / 'd'), '-o', out, '-q', '--time-offset', '1000']) == 0
    bag = read_bag(out)
    assert_stamps_monotonic(bag)  # header stamps equal the bag time
    assert [t for t, _ in bag['/odom']] == pytest.approx([1001.0, 1001.1, 1001.2, 1001.3])
    assert bag['/tf'][0][1].transforms[0].header.stamp.to_sec() == pytest.approx(1001.0)
    assert bag['/ground_truth/landmarks'][0][1].header.stamp.to_sec() == pytest.approx(1001.0)


@pytest.mark.parametrize('sensor, pattern', [
    ('ODOMETRY 0.1 0.2\n', 'sensor_data.dat:1: expected ODOMETRY r1 t r2 (4 fields), got 3 fields'),
    ('ODOMETRY 0 1 0\nSENSOR 1 abc 0.2\n', "sensor_data.dat:2: expected numbers as range bearing, got 'abc'"),
    ('ODOMETRY 0 1 0\nSENSOR x 1 0.2\n', "sensor_data.dat:2: expected an integer landmark id, got 'x'"),
    ('', 'sensor_data.dat: expected "ODOMETRY r1 t r2" and "SENSOR id range bearing" lines, got an empty file'),
    ('ODOMETRY 0 1 0\nLASER 1 2 3\n', "sensor_data.dat:2: expected a line starting with 'ODOMETRY' or 'SENSOR'"),
])
def test_malformed(tmp_path, capsys, sensor, pattern):
    out = tmp_path / 'bad.bag'
    code, _, err = run_main(freiburg.main, [write(tmp_path / 'd', sensor), '-o', str(out), '-q'], capsys)
    assert code == 1 and pattern in err, err
    assert not [f for f in os.listdir(str(tmp_path)) if f.endswith('.bag')]


def test_skip_bad(tmp_path, capsys):
    out = str(tmp_path / 's.bag')
    code, stdout, _ = run_main(freiburg.main, [write(tmp_path / 'd', SENSOR + 'SENSOR 1 2\n'), '-o', out, '-q',
                                               '--skip-bad'], capsys)
    assert code == 0 and 'malformed lines skipped (--skip-bad): 1' in stdout
    assert sum(len(m.trunks) for _, m in read_bag(out)['/landmarks']) == 3


def test_real_data(tmp_path):
    d = os.path.dirname(data_path('freiburg_course', 'sensor_data.dat'))
    out = str(tmp_path / 'freiburg.bag')
    summary = cc.convert_to_bag(freiburg.convert, freiburg.build_parser().parse_args([d, '-o', out]))
    assert summary.counts['/odom'] == 332 and summary.counts['/landmarks'] == 332  # start pose + 331 steps
    assert summary.counts['/ground_truth/landmarks'] == 1
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    obs = [t for _, m in bag['/landmarks'] for t in m.trunks]
    assert len(obs) == 1212 and all(t.id == -1 for t in obs)  # no given association: that is ground truth
    # every array states the sensor's scope: all round, out to the file's largest range less two range sigmas
    arr = bag['/landmarks'][5][1]
    assert (arr.min_range, arr.fov_min, arr.fov_max) == (0.0, -math.pi, math.pi)
    assert arr.max_range == pytest.approx(5.0)
    assert all(t.range >= 0 for t in obs)
    first = bag['/landmarks'][1][1].trunks[0]
    assert (first.range, first.bearing) == pytest.approx((1.89645381418, 0.374031885671))
    truth = bag['/ground_truth/landmarks'][0][1]
    assert len(truth.trunks) == 9 and (truth.trunks[0].id, truth.trunks[0].center.x, truth.trunks[0].center.y) == \
        (1, 2.0, 1.0)
    # the odometry is the rot1-trans-rot2 chain; the first step is 0.1 m ahead
    assert pose2(bag['/odom'][1][1])[0] == pytest.approx(0.100072845247 * math.cos(0.100692392654))
    steps, _ = freiburg.read_sensor_data(os.path.join(d, 'sensor_data.dat'))
    x, y, th = freiburg.integrate_odometry(steps)
    assert pose2(bag['/odom'][-1][1]) == pytest.approx((x[-1], y[-1], th[-1]))
    # observed landmarks seen from the (noisy) odometry pose land near their true positions early on
    truth_xy = {t.id: (t.center.x, t.center.y) for t in truth.trunks}
    steps_obs = steps[0].observations
    px, py, pth = pose2(bag['/odom'][1][1])
    for (i, r, b) in steps_obs:
        wx, wy = px + r * math.cos(pth + b), py + r * math.sin(pth + b)
        assert math.hypot(wx - truth_xy[i][0], wy - truth_xy[i][1]) < 0.5
