"""ese650_to_bag: skid-steer odometry, wheel ticks, IMU, a Hokuyo file in the data set's exact layout (written
here), wrong .mat layouts, and a real run."""
import math
import os

import numpy as np
import pytest

from bagcheck import (assert_stamps_monotonic, data_path, frames_of, pose2, read_bag, run_main,
                      static_transforms)
from rbpf_slam import convert_common as cc
from rbpf_slam import ese650

pytest.importorskip('rosbag')
scipy_io = pytest.importorskip('scipy.io')

T0 = 1298445274.5


def write_run(d, counts, ts, imu=True, hokuyo=None):
    """Encoders<N>.mat (struct Encoders: counts 4 x K, ts 1 x K), imu<N>.mat (ts, vals), as the data set has them."""
    d.mkdir(exist_ok=True)
    scipy_io.savemat(str(d / 'Encoders7.mat'), {'Encoders': {'counts': np.asarray(counts, dtype=np.int16),
                                                             'ts': np.asarray(ts, dtype=float).reshape(1, -1)}})
    if imu:
        its = np.arange(ts[0], ts[-1], 0.01)
        vals = np.zeros((6, len(its)))
        vals[2] = 1.0       # +1 g on z at rest
        vals[5] = 0.25      # yaw rate [rad/s]
        scipy_io.savemat(str(d / 'imu7.mat'), {'ts': its.reshape(1, -1), 'vals': vals})
    if hokuyo is not None:
        scipy_io.savemat(str(d / 'Hokuyo7.mat'), {'Hokuyo0': hokuyo})
    return str(d)


def small_hokuyo(ts0, n_scans=5):
    """A Hokuyo file in the exact layout of the data set's Hokuyo<N>.mat: struct Hokuyo0 with ranges
    (1081 x S, m), angles (1081 x 1, rad, -135..135 deg) and ts (1 x S)."""
    angles = np.radians(np.linspace(-135.0, 135.0, 1081)).reshape(-1, 1)
    ranges = np.full((1081, n_scans), 4.0)
    ranges[540, :] = np.arange(n_scans) + 1.0   # straight ahead: 1, 2, 3 ... m
    ranges[0, :] = 0.0                          # error code
    ranges[1080, :] = 65.0                      # beyond range_max
    ts = (ts0 + 0.025 * np.arange(n_scans)).reshape(1, -1)
    return {'ranges': ranges, 'angles': angles, 'ts': ts}


def test_straight_and_turning_odometry():
    per = ese650.METRES_PER_COUNT
    assert per == pytest.approx(math.pi * 0.254 / 360)
    counts = np.array([[10, 10], [10, 10], [10, 10], [10, 10]])  # FR FL RR RL
    x, y, th, _, _ = ese650.wheel_odometry(counts)
    assert (x[-1], y[-1], th[-1]) == pytest.approx((20 * per, 0.0, 0.0))
    counts = np.array([[5], [-5], [5], [-5]])  # right forward, left backward: turn left on the spot
    x, y, th, _, _ = ese650.wheel_odometry(counts, track=0.7)
    assert th[-1] == pytest.approx(10 * per / 0.7) and (x[-1], y[-1]) == pytest.approx((0.0, 0.0))
    assert ese650.DEFAULT_TRACK == pytest.approx(1.85 * (0.31115 + 0.47625) / 2)


def test_synthetic_run_with_hokuyo_in_the_data_set_layout(tmp_path, capsys):
    k = 40
    ts = T0 + 0.025 * np.arange(k)
    counts = np.tile(np.array([[3], [2], [3], [2]]), (1, k))
    counts[:, 0] = 0
    d = write_run(tmp_path / 'run', counts, ts, hokuyo=small_hokuyo(T0 + 0.01))
    out = str(tmp_path / 'r.bag')
    code, stdout, _ = run_main(ese650.main, [d, '7', '-o', out, '-q'], capsys)
    assert code == 0, stdout
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    assert len(bag['/odom']) == k and len(bag['/wheel_ticks']) == k and len(bag['/scan']) == 5
    assert bag['/odom'][0][0] == pytest.approx(T0, abs=1e-6)
    # odometry: the same arithmetic as wheel_odometry on the counts
    x, y, th, _, _ = ese650.wheel_odometry(counts)
    assert pose2(bag['/odom'][-1][1]) == pytest.approx((x[-1], y[-1], th[-1]), abs=1e-9)
    assert bag['/odom'][-1][1].twist.twist.linear.x == pytest.approx(2.5 * ese650.METRES_PER_COUNT / 0.025, rel=1e-5)
    # ticks: cumulative wheel angles; the raw counts come back exactly
    js = bag['/wheel_ticks'][-1][1]
    assert list(js.name) == ['front_right_wheel', 'front_left_wheel', 'rear_right_wheel', 'rear_left_wheel']
    back = np.round(np.array(js.position) * 360 / (2 * math.pi)).astype(int)
    assert list(back) == list(counts.sum(axis=1))
    # IMU in SI units
    imu = bag['/imu/data'][0][1]
    assert imu.linear_acceleration.z == pytest.approx(9.80665) and imu.angular_velocity.z == pytest.approx(0.25)
    assert imu.orientation_covariance[0] == -1 and imu.header.frame_id == 'base_link'
    # scans: angles, units and REP-117 from the data set's layout
    scan = bag['/scan'][2][1]
    assert len(scan.ranges) == 1081 and scan.header.frame_id == 'laser'
    assert scan.angle_min == pytest.approx(math.radians(-135), abs=1e-6)
    assert scan.angle_max == pytest.approx(math.radians(135), abs=1e-5)
    assert scan.angle_increment == pytest.approx(math.radians(0.25), abs=1e-7)
    assert scan.ranges[540] == pytest.approx(3.0) and math.isnan(scan.ranges[0]) and math.isinf(scan.ranges[1080])
    assert (scan.range_min, scan.range_max) == pytest.approx((0.1, 30.0))
    mount = static_transforms(bag)[('base_link', 'laser')].transform.translation
    assert (mount.x, mount.y, mount.z) == pytest.approx((0.29833 - 0.3302 / 2, 0.0, 0.51435))


def test_run_without_imu_and_hokuyo(tmp_path, capsys):
    ts = T0 + 0.025 * np.arange(5)
    d = write_run(tmp_path / 'run', np.ones((4, 5)), ts, imu=False)
    out = str(tmp_path / 'r.bag')
    code, stdout, _ = run_main(ese650.main, [d, '7', '-o', out, '-q'], capsys)
    assert code == 0 and 'no IMU file' in stdout and 'no Hokuyo file' in stdout
    assert set(read_bag(out)) == {'/odom', '/tf', '/wheel_ticks'}


@pytest.mark.parametrize('content, pattern', [
    ({'Encoders': {'counts': np.zeros((3, 4)), 'ts': np.zeros((1, 4))}},
     "Encoders7.mat: expected a struct 'Encoders' with fields 'counts' (4 x K integers: FR FL RR RL) and 'ts' "
     "(1 x K seconds), got counts 3x4"),
    ({'Enc': {'counts': np.zeros((4, 4)), 'ts': np.zeros((1, 4))}},
     "Encoders7.mat: expected a struct 'Encoders' with fields 'counts'"),
    ({'Encoders': {'counts': np.zeros((4, 4)), 'ts': np.array([[3.0, 2.0, 4.0, 5.0]])}},
     'Encoders7.mat: expected increasing encoder time stamps, got 1 steps back or repeated'),
    (None, 'Encoders7.mat: expected a MATLAB .mat file'),
])
def test_wrong_mat_layout(tmp_path, capsys, content, pattern):
    d = tmp_path / 'run'
    d.mkdir()
    if content is None:
        (d / 'Encoders7.mat').write_text('counts ts\n1 2 3\n')
    else:
        scipy_io.savemat(str(d / 'Encoders7.mat'), content)
    out = tmp_path / 'bad.bag'
    code, _, err = run_main(ese650.main, [str(d), '7', '-o', str(out), '-q'], capsys)
    assert code == 1 and pattern in err, err
    assert not [f for f in os.listdir(str(tmp_path)) if f.endswith('.bag')]


def test_wrong_hokuyo_layout(tmp_path, capsys):
    ts = T0 + 0.025 * np.arange(5)
    bad = small_hokuyo(T0)
    bad['angles'] = bad['angles'][:1000]
    d = write_run(tmp_path / 'run', np.ones((4, 5)), ts, hokuyo=bad)
    code, _, err = run_main(ese650.main, [d, '7', '-o', str(tmp_path / 'b.bag'), '-q'], capsys)
    assert code == 1 and "Hokuyo7.mat: expected a struct 'Hokuyo0' with fields 'ranges' (n x S metres)" in err
    assert 'got ranges 1081x5, angles of 1000' in err


def test_real_run(tmp_path):
    d = os.path.dirname(data_path('ese650', 'Encoders20.mat'))
    out = str(tmp_path / 'ese20.bag')
    summary = cc.convert_to_bag(ese650.convert, ese650.build_parser().parse_args([d, '20', '-o', out]))
    assert summary.counts['/odom'] == 4956 and summary.counts['/wheel_ticks'] == 4956
    assert summary.counts['/imu/data'] == 12187 and '/scan' not in summary.counts
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    assert frames_of(bag, '/odom') == {'odom'} and frames_of(bag, '/imu/data') == {'base_link'}
    enc = scipy_io.loadmat(os.path.join(d, 'Encoders20.mat'))['Encoders'][0, 0]
    assert bag['/odom'][0][0] == pytest.approx(enc['ts'][0, 0], abs=1e-6)
    assert bag['/odom'][-1][0] == pytest.approx(enc['ts'][0, -1], abs=1e-6)
    js = bag['/wheel_ticks'][-1][1]
    back = np.round(np.array(js.position) * 360 / (2 * math.pi)).astype(int)
    assert list(back) == [43606, 43552, 43584, 43549]  # counts summed over the run: FR FL RR RL
    # 96.6 m driven; gravity on z in m/s^2
    assert 'effective track 0.7283 m; 96.6 m driven' in summary.text()
    acc = np.array([[m.linear_acceleration.x, m.linear_acceleration.y, m.linear_acceleration.z]
                    for _, m in bag['/imu/data'][:100]])
    assert np.mean(acc[:, 2]) == pytest.approx(9.8, abs=0.2)


def test_limit_cuts_imu_at_the_last_encoder_read(tmp_path):
    d = os.path.dirname(data_path('ese650', 'Encoders23.mat'))
    out = str(tmp_path / 'part.bag')
    summary = cc.convert_to_bag(ese650.convert, ese650.build_parser().parse_args(
        [d, '23', '-o', out, '--limit', '400']))
    assert summary.counts['/odom'] == 400
    bag = read_bag(out)
    assert bag['/imu/data'][-1][0] <= bag['/odom'][-1][0]
