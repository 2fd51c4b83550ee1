"""Helpers of the converter tests: where the real data is, reading a bag back, checking stamps and frames."""
import math
import os

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# The data sets: $RBPF_SLAM_DATA when set, else the folder beside the repository.
DATA = os.path.normpath(os.environ.get('RBPF_SLAM_DATA') or os.path.join(ROOT, '..', 'shared', 'data'))


def built_tool(name):
    """Path of a C++ tool of the package as built by scripts/bootstrap (RBPF_WS: another workspace)."""
    ws = os.environ.get('RBPF_WS', os.path.join(ROOT, 'build'))
    path = os.path.join(ws, 'devel', 'lib', 'rbpf_slam', name)
    if not os.path.exists(path):
        raise RuntimeError('%s is not built (%s); run scripts/bootstrap' % (name, path))
    return path


def data_path(*parts):
    """A file of the real data sets in DATA ($RBPF_SLAM_DATA, else <repo>/../shared/data); the test is skipped
    when it is absent."""
    path = os.path.join(DATA, *parts)
    if not os.path.exists(path):
        pytest.skip('real data not found: %s (the data sets live in $RBPF_SLAM_DATA or <repo>/../shared/data)'
                    % path)
    return path


def read_bag(path):
    """{topic: [(bag time [s], msg), ...]} of a whole bag, read back with rosbag."""
    import rosbag
    out = {}
    with rosbag.Bag(path) as bag:
        for topic, msg, t in bag.read_messages():
            out.setdefault(topic, []).append((t.to_sec(), msg))
    return out


def connection_latched(path, topic):
    import rosbag
    with rosbag.Bag(path) as bag:
        for c in bag._get_connections(topics=[topic]):
            return c.header.get('latching') in ('1', b'1')
    return False


def assert_stamps_monotonic(bag, strict_tf=True):
    """Every topic's header stamps are non-decreasing and equal to the bag time; odom -> base_link on /tf
    strictly increasing (tf2 rejects repeated stamps)."""
    for topic, items in bag.items():
        stamps = []
        for t, msg in items:
            if hasattr(msg, 'header'):
                s = msg.header.stamp.to_sec()
                assert abs(s - t) < 1e-6, '%s: header stamp %.6f, bag time %.6f' % (topic, s, t)
            else:  # tf2_msgs/TFMessage
                s = msg.transforms[0].header.stamp.to_sec()
            stamps.append(s)
        d = np.diff(stamps)
        assert np.all(d >= 0), '%s: %d stamps go backwards' % (topic, int(np.sum(d < 0)))
        if topic == '/tf' and strict_tf:
            assert np.all(d > 0), '/tf: %d repeated stamps' % int(np.sum(d == 0))


def yaw(q):
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def pose2(msg):
    """(x, y, yaw) of an Odometry or TransformStamped."""
    if hasattr(msg, 'pose'):
        p = msg.pose.pose
        return p.position.x, p.position.y, yaw(p.orientation)
    tr = msg.transform
    return tr.translation.x, tr.translation.y, yaw(tr.rotation)


def frames_of(bag, topic):
    return set(msg.header.frame_id for _, msg in bag[topic])


def static_transforms(bag):
    """{(parent, child): TransformStamped} from /tf_static."""
    out = {}
    for _, msg in bag.get('/tf_static', []):
        for tf in msg.transforms:
            out[(tf.header.frame_id, tf.child_frame_id)] = tf
    return out


def run_main(main, argv, capsys):
    """Run a converter's main in-process; returns (exit code, stdout, stderr)."""
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err
