"""The bag runner (slam_bag) against bad arguments, bad bags and signals: one line naming the problem, a
non-zero exit, and no output file left behind; malformed messages inside a bag are dropped and counted."""
import math
import os
import signal
import struct
import subprocess
import time

import pytest
from bagcheck import built_tool

rosbag = pytest.importorskip('rosbag')
from geometry_msgs.msg import TransformStamped  # noqa: E402
from nav_msgs.msg import Odometry  # noqa: E402
from sensor_msgs.msg import LaserScan, PointCloud2, PointField  # noqa: E402
from tf2_msgs.msg import TFMessage  # noqa: E402
import rospy  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


_tool = built_tool


def _cloud(stamp, kind='float32', n_trunk=400, ahead=4.0):
    """A trunk of radius 0.2 m @p ahead metres ahead (points from 0.5 m below to 1.5 m above the sensor) as a
    cloud."""
    pts = []
    for k in range(20):
        z = -0.5 + 0.1 * k
        for j in range(n_trunk // 20):
            phi = math.pi - 1.0 + 2.0 * j / (n_trunk // 20)
            pts.append((ahead + 0.2 * math.cos(phi), 0.2 * math.sin(phi), z))
    fmt, size, dt = ('fff', 4, PointField.FLOAT32) if kind != 'float64' else ('ddd', 8, PointField.FLOAT64)
    msg = PointCloud2()
    msg.header.stamp = stamp
    msg.header.frame_id = 'lidar'
    msg.height, msg.width = 1, len(pts)
    msg.fields = [PointField(n, i * size, dt, 1) for i, n in enumerate('xyz')]
    msg.point_step = 3 * size
    msg.row_step = msg.point_step * msg.width
    msg.data = b''.join(struct.pack('<' + fmt, *p) for p in pts)
    if kind == 'long':
        msg.data += b'\0' * 5
    elif kind == 'time outside':
        msg.fields.append(PointField('time', 1000, PointField.FLOAT32, 1))
    return msg


def _scan(stamp):
    msg = LaserScan()
    msg.header.stamp = stamp
    msg.header.frame_id = 'laser'
    msg.angle_min, msg.angle_increment = -1.5, 0.01
    msg.range_min, msg.range_max = 0.1, 30.0
    msg.ranges = [min(4.0 / max(math.cos(-1.5 + 0.01 * i), 1e-3), 3.0 / max(abs(math.sin(-1.5 + 0.01 * i)), 1e-3))
                  for i in range(301)]
    return msg


def _bag(path, n=30, kinds=(), scans=False, clouds=True, odom=True):
    """n sweeps at 10 Hz (clouds and/or scans), odometry at 20 Hz driving 0.05 m per sweep, mounts on /tf_static.
    kinds maps a sweep index to a malformed cloud kind."""
    kinds = dict(kinds)
    with rosbag.Bag(path, 'w') as bag:
        t0 = rospy.Time(100)
        tf = TFMessage()
        for child in ('lidar', 'laser'):
            t = TransformStamped()
            t.header.stamp = t0
            t.header.frame_id = 'base_link'
            t.child_frame_id = child
            t.transform.translation.z = 1.0
            t.transform.rotation.w = 1.0
            tf.transforms.append(t)
        bag.write('/tf_static', tf, t0)
        for k in range(2 * n + 2):
            stamp = t0 + rospy.Duration(0.05 * k)
            if odom:
                od = Odometry()
                od.header.stamp = stamp
                od.header.frame_id = 'odom'
                od.pose.pose.position.x = 0.025 * k
                od.pose.pose.orientation.w = 1.0
                bag.write('/odom', od, stamp)
            if k % 2 == 1 and k // 2 < n:
                if clouds:
                    # One tree standing 5 m ahead of the start: the robot drives towards it.
                    bag.write('/points', _cloud(stamp, kinds.get(k // 2, 'float32'), ahead=5.0 - 0.025 * k), stamp)
                if scans:
                    bag.write('/scan', _scan(stamp), stamp)
    return path


def _run(*args, **kw):
    return subprocess.run([_tool('slam_bag')] + [str(a) for a in args], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, universal_newlines=True, **kw)


def _one_line(stderr):
    lines = [l for l in stderr.splitlines() if l.strip() and 'warning' not in l]
    assert len(lines) == 1 and 'Traceback' not in stderr, stderr
    return lines[0]


@pytest.mark.parametrize('args, says', [
    (['--particles', '0'], '--particles must be in 1..'),
    (['--particles', '-5'], '--particles must be in 1..'),
    (['--particles', 'ten'], '--particles must be an integer'),
    (['--seed', 'abc'], '--seed must be an integer'),
    (['--track', 'nan'], '--track must be a number'),
    (['--frobnicate', '1'], "unknown argument '--frobnicate'"),
    (['--out'], '--out needs a value'),
    (['--filter', 'fastslam', '--every-scan'], '--every-scan goes with --filter grid'),
])
def test_bad_arguments_are_one_line_usage_errors(tmp_path, args, says):
    r = _run('--filter', 'grid', '--bag', tmp_path / 'x.bag', *args)
    assert r.returncode == 2
    assert says in _one_line(r.stderr)


def test_grid_particles_beyond_the_bound(tmp_path):
    bag = _bag(str(tmp_path / 'b.bag'), n=3, scans=True)
    r = _run('--filter', 'grid', '--bag', bag, '--particles', '10000', '--out', tmp_path / 'out')
    assert r.returncode == 1 and 'particles must be in 1..5000' in _one_line(r.stderr)
    assert not (tmp_path / 'out').exists()


@pytest.mark.parametrize('args, says', [
    (['--filter', 'grid', '--scan', '/nope'], 'no topic /nope (--scan)'),
    (['--filter', 'grid', '--odom', '/nope'], 'no topic /nope (--odom)'),
    (['--filter', 'grid', '--scan', '/odom'], '/odom is nav_msgs/Odometry, not sensor_msgs/LaserScan'),
    (['--filter', 'fastslam', '--points', '/scan'], '/scan is sensor_msgs/LaserScan, not sensor_msgs/PointCloud2'),
    (['--filter', 'fastslam', '--odom', '/nope'], 'no topic /nope (--odom)'),
])
def test_wrong_topics_name_what_the_bag_holds(tmp_path, args, says):
    bag = _bag(str(tmp_path / 'b.bag'), n=3, scans=True)
    r = _run('--bag', bag, '--out', tmp_path / 'out', *args)
    line = _one_line(r.stderr)
    assert r.returncode == 1 and says in line and 'the bag holds: /odom [nav_msgs/Odometry]' in line, line
    assert not (tmp_path / 'out').exists()


def test_a_bag_without_scans_needs_odometry_only(tmp_path):
    bag = _bag(str(tmp_path / 'b.bag'), n=3, clouds=False)
    r = _run('--filter', 'grid', '--bag', bag, '--out', tmp_path / 'out')
    assert r.returncode == 1 and 'no topic /scan' in _one_line(r.stderr)
    r = _run('--filter', 'grid', '--bag', bag, '--odometry-only', '--out', tmp_path / 'out', '--quiet')
    assert r.returncode == 0, r.stderr
    assert os.path.getsize(str(tmp_path / 'out' / 'odometry_all.tum')) > 0


def test_bad_paths(tmp_path):
    bag = _bag(str(tmp_path / 'b.bag'), n=3)
    r = _run('--bag', tmp_path, '--out', tmp_path / 'out')
    assert r.returncode == 1 and 'a folder, not a bag file' in _one_line(r.stderr)
    (tmp_path / 'file.txt').write_text('x')
    r = _run('--bag', bag, '--out', tmp_path / 'file.txt' / 'out')
    assert r.returncode == 1 and 'not a folder' in _one_line(r.stderr)
    (tmp_path / 'garbage.bag').write_bytes(b'\x00garbage' * 100)
    r = _run('--bag', tmp_path / 'garbage.bag', '--out', tmp_path / 'out2')
    assert r.returncode == 1 and 'garbage.bag' in _one_line(r.stderr)
    assert not (tmp_path / 'out2').exists()


def test_float64_clouds_are_read(tmp_path):
    bag = str(tmp_path / 'b.bag')
    _bag(bag, n=20, kinds={k: 'float64' for k in range(20)})
    out = tmp_path / 'out'
    r = _run('--bag', bag, '--out', out)
    assert r.returncode == 0, r.stderr
    assert '20 clouds' in r.stdout and '0 messages dropped' in r.stdout, r.stdout
    with open(str(out / 'map.csv')) as f:
        assert len(f.read().strip().splitlines()) >= 2  # the header and the trunk


def test_malformed_clouds_in_a_bag_are_dropped_and_counted(tmp_path):
    bag = str(tmp_path / 'b.bag')
    _bag(bag, n=20, kinds={5: 'long', 6: 'time outside', 7: 'long'})
    r = _run('--bag', bag, '--out', tmp_path / 'out')
    assert r.returncode == 0, r.stderr
    assert '17 clouds' in r.stdout and '3 messages dropped' in r.stdout, r.stdout
    assert r.stderr.count('dropped') == 3 and 'data holds' in r.stderr and 'field time' in r.stderr, r.stderr


def test_a_looped_bag_restarts_the_filter(tmp_path):
    first, second = str(tmp_path / 'a.bag'), str(tmp_path / 'looped.bag')
    _bag(first, n=20)
    with rosbag.Bag(first) as a, rosbag.Bag(second, 'w') as b:
        messages = list(a.read_messages())
        for topic, msg, t in messages:
            b.write(topic, msg, t)
        for topic, msg, t in messages:  # the same drive again, stamps as recorded: time jumps back 2 s (recorded after the first)
            b.write(topic, msg, t + rospy.Duration(2.2))
    r = _run('--bag', second, '--out', tmp_path / 'out')
    assert r.returncode == 0, r.stderr
    assert '1 restarts' in r.stdout, r.stdout
    assert '40 clouds' in r.stdout, r.stdout
    # The map before the restart is kept beside the new one.
    before = _trees(tmp_path / 'out' / 'map.restart1.csv')
    assert before == _trees(tmp_path / 'out' / 'map.csv') == 1
    assert 'the map before restart 1 holds 1 trees; saved to' in r.stderr, r.stderr


def test_a_looped_bag_keeps_the_grid_map_before_the_restart(tmp_path):
    first, second = str(tmp_path / 'a.bag'), str(tmp_path / 'looped.bag')
    _bag(first, n=20, scans=True, clouds=False)
    with rosbag.Bag(first) as a, rosbag.Bag(second, 'w') as b:
        messages = list(a.read_messages())
        for topic, msg, t in messages:
            b.write(topic, msg, t)
        for topic, msg, t in messages:
            b.write(topic, msg, t + rospy.Duration(2.2))
    r = _run('--filter', 'grid', '--bag', second, '--every-scan', '--out', tmp_path / 'out')
    assert r.returncode == 0, r.stderr
    assert '1 restarts' in r.stdout, r.stdout
    assert 'the map before restart 1 is saved to' in r.stderr, r.stderr
    assert (tmp_path / 'out' / 'map.restart1.yaml').is_file() and (tmp_path / 'out' / 'map.restart1.pgm').is_file()


def _trees(path):
    with open(str(path)) as f:
        return len([l for l in f.read().splitlines() if l and not l.startswith('#')]) - 1


def _insert(src, dst, extra):
    """Copies the bag src to dst with the messages extra (topic, msg, record time) among them."""
    with rosbag.Bag(src) as a, rosbag.Bag(dst, 'w') as b:
        for topic, msg, t in sorted(list(a.read_messages()) + list(extra), key=lambda m: m[2]):
            b.write(topic, msg, t)
    return dst


def test_single_late_messages_keep_the_map(tmp_path):
    """One odometry message 2 s late and one cloud 5 s late: both dropped, no restart, the same map."""
    clean = _bag(str(tmp_path / 'clean.bag'), n=30)
    late_odom = Odometry()
    late_odom.header.stamp = rospy.Time(101.0)
    late_odom.header.frame_id = 'odom'
    late_odom.pose.pose.orientation.w = 1.0
    late = _insert(clean, str(tmp_path / 'late.bag'), [('/odom', late_odom, rospy.Time(103.01)),
                                                      ('/points', _cloud(rospy.Time(97.5)), rospy.Time(102.51))])
    a = _run('--bag', clean, '--out', tmp_path / 'a')
    b = _run('--bag', late, '--out', tmp_path / 'b')
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    assert '0 restarts' in b.stdout and '2 messages dropped' in b.stdout, b.stdout
    assert 'before the previous stamp by more than the time jump threshold' in b.stderr, b.stderr
    assert _trees(tmp_path / 'b' / 'map.csv') == _trees(tmp_path / 'a' / 'map.csv') == 1


def test_odometry_without_an_orientation_is_dropped(tmp_path):
    clean = _bag(str(tmp_path / 'clean.bag'), n=10)
    zero = Odometry()
    zero.header.stamp = rospy.Time(100.3001)
    zero.header.frame_id = 'odom'
    r = _run('--bag', _insert(clean, str(tmp_path / 'zero.bag'), [('/odom', zero, rospy.Time(100.3001))]),
             '--out', tmp_path / 'out')
    assert r.returncode == 0, r.stderr
    assert '1 messages dropped' in r.stdout, r.stdout
    assert 'orientation not a unit quaternion (length 0.000000)' in r.stderr, r.stderr


def _trunk_bag(path, good=20, unreadable=12):
    """TrunkArrays of three trunks on /landmarks at 10 Hz while driving 0.05 m per sweep: `good` readable ones, then
    `unreadable` whose every trunk has a NaN centre."""
    from rbpf_slam.msg import Trunk, TrunkArray
    with rosbag.Bag(path, 'w') as bag:
        t0 = rospy.Time(100)
        tf = TFMessage()
        t = TransformStamped()
        t.header.stamp, t.header.frame_id, t.child_frame_id = t0, 'base_link', 'lidar'
        t.transform.rotation.w = 1.0
        tf.transforms.append(t)
        bag.write('/tf_static', tf, t0)
        n = good + unreadable
        for k in range(2 * n + 2):
            stamp = t0 + rospy.Duration(0.05 * k)
            od = Odometry()
            od.header.stamp, od.header.frame_id = stamp, 'odom'
            od.pose.pose.position.x = 0.025 * k
            od.pose.pose.orientation.w = 1.0
            bag.write('/odom', od, stamp)
            if k % 2 == 1 and k // 2 < n:
                a = TrunkArray()
                a.header.stamp, a.header.frame_id = stamp, 'lidar'
                for (x, y) in ((4.0, 1.0), (6.0, -2.0), (3.0, -3.0)):
                    tr = Trunk()
                    tr.center.x = x - 0.025 * k
                    tr.center.y = float('nan') if k // 2 >= good else y
                    tr.radius, tr.radius_variance = 0.2, 1e-4
                    tr.covariance = [1e-3, 0.0, 0.0, 1e-3]
                    tr.method = Trunk.METHOD_CIRCLE
                    a.trunks.append(tr)
                bag.write('/landmarks', a, stamp)
    return path


def test_arrays_of_unreadable_trunks_are_not_looks(tmp_path):
    """Twelve arrays whose trunks are all NaN after the map was made: dropped whole, the three trees stay."""
    r = _run('--bag', _trunk_bag(str(tmp_path / 'nan.bag')), '--landmarks', '/landmarks', '--out', tmp_path / 'out')
    assert r.returncode == 0, r.stderr
    assert '20 clouds' in r.stdout, r.stdout
    assert '12 messages dropped' in r.stdout and 'not a look that saw no tree' in r.stderr, r.stdout + r.stderr
    assert _trees(tmp_path / 'out' / 'map.csv') == 3


def test_maps_beyond_their_bounds_are_refused_with_the_line(tmp_path):
    bag = _bag(str(tmp_path / 'b.bag'), n=3)
    absurd = tmp_path / 'absurd.csv'
    absurd.write_text('id,x,y,dbh\n1,2,3,0.3\n2,1e308,3,0.3\n')
    r = _run('--bag', bag, '--map', absurd, '--out', tmp_path / 'out')
    assert r.returncode == 1 and 'absurd.csv:3: expected |x|, |y| <= 100000 m' in _one_line(r.stderr), r.stderr
    # A million trees: refused at the first tree beyond max_landmarks, at once (it once hung for minutes).
    huge = tmp_path / 'huge.csv'
    with open(str(huge), 'w') as f:
        f.write('id,x,y,dbh\n')
        f.writelines('%d,%d,%d,0.3\n' % (i, i % 1000, i // 1000) for i in range(1000000))
    start = time.time()
    r = _run('--bag', bag, '--map', huge, '--out', tmp_path / 'out', timeout=120)
    assert r.returncode == 1 and 'huge.csv:20002: more than 20000 trees (max_landmarks)' in _one_line(r.stderr), r.stderr
    assert not (tmp_path / 'out').exists()
    print('a map of a million trees refused in %.2f s' % (time.time() - start))


@pytest.mark.parametrize('signum', [signal.SIGTERM, signal.SIGHUP, signal.SIGINT])
def test_a_signal_leaves_no_output(tmp_path, signum):
    bag = str(tmp_path / 'b.bag')
    _bag(bag, n=600, scans=True, clouds=False)
    out = tmp_path / 'out'
    proc = subprocess.Popen([_tool('slam_bag'), '--filter', 'grid', '--bag', bag, '--out', str(out), '--particles',
                             '300', '--config', os.path.join(ROOT, 'config', 'grid_slam_advanced.yaml'),
                             '--config', os.path.join(ROOT, 'config', 'grid_slam.yaml')],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    time.sleep(2.0)
    assert proc.poll() is None, 'finished before the signal: make the bag longer'
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + signum, err
    assert 'interrupted by signal %d; no output written' % signum in err
    assert not out.exists() or os.listdir(str(out)) == []
