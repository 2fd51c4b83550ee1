"""trajectory_eval on a small synthetic bag whose answer is known: a reference with several poses at one stamp
(as a converter's re-timing leaves them), the package's TUM files and files in the ``t x y theta`` layout of
other SLAM systems, paired by stamp and by index; both ATEs; the odometry written as a trajectory; bad input."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'src'))
from rbpf_slam import evaluate as ev  # noqa: E402
from test_converter_faults import assert_fails_cleanly, run  # noqa: E402
from test_evaluate import PAIRING_REF, PAIRING_REF_T, PAIRING_RUN_T, _compose, _pairing_run  # noqa: E402

rosbag = pytest.importorskip('rosbag')
from rbpf_slam import convert_msgs as cm  # noqa: E402

T0 = 100.0


def _odometry_pose(t):
    """The bag's odometry: 0.5 m/s straight on, turning 0.1 rad/s (linear in time: interpolation is exact)."""
    return 0.5 * (t - T0 + 0.5), 0.0, 0.1 * (t - T0 + 0.5)


def _bag(path):
    """/ground_truth/odom: the reference poses of test_evaluate's pairing case (three at one stamp, two at
    another); /odom every 0.25 s from 0.5 s before the first to 0.5 s after the last."""
    with rosbag.Bag(str(path), 'w') as bag:
        for t in np.arange(T0 - 0.5, T0 + PAIRING_REF_T[-1] + 0.5 + 1e-9, 0.25):
            bag.write('/odom', cm.odometry(t, 'odom', 'base_link', *_odometry_pose(t)), cm.ros_time(t))
        for t, (x, y, a) in zip(T0 + PAIRING_REF_T, PAIRING_REF):
            bag.write('/ground_truth/odom', cm.odometry(t, 'map', 'base_link', x, y, a), cm.ros_time(t))
    return str(path)


def _table(stdout):
    lines = stdout.splitlines()
    assert lines[0].split() == ['trajectory', 'poses', 'RPE', 'm', 'RPE', 'deg', 'RPErms', 'm', 'RPErms', 'deg',
                                'ATEfit', 'm', 'ATEfirst', 'm'], lines[0]
    return {line.split()[0]: [float(v) for v in line.split()[1:]] for line in lines[1:]}


def _eval(*args):
    r = run('trajectory_eval', *args)
    assert r.returncode == 0 and not r.stderr, r.stderr
    return _table(r.stdout)


def test_tum_and_peer_files_by_stamp_and_by_index(tmp_path):
    bag = _bag(tmp_path / 'ref.bag')
    # The package's run: stamped as the bag, two poses sharing the stamp of three reference poses.
    poses = _pairing_run()
    tum = tmp_path / 'estimate.tum'
    tum.write_text(ev.tum_text(T0 + PAIRING_RUN_T, poses[:, :2], poses[:, 2]))
    # A peer's file: one line per reference pose in order, stamped by another clock (0.5 s off, two lines
    # out of order), in another frame, its last pose 0.3 m off.
    peer_poses = np.array([_compose((-1.0, 2.0, -0.6), p) for p in PAIRING_REF])
    peer_poses[-1, :2] += [0.3, 0.0]
    stamps = T0 + 0.5 + PAIRING_REF_T + np.array([0, 0, 0.03, 0.01, 0.02, 0, 0.2, 0.1, 0])
    peer = tmp_path / 'peer.txt'
    peer.write_text(''.join('%.4f %.9f %.9f %.9f\n' % (t, x, y, a) for t, (x, y, a) in zip(stamps, peer_poses)))
    rows = _eval('--bag', bag, tum, peer)
    assert rows[str(tum)] == pytest.approx([8, 0, 0, 0, 0, 0, 0], abs=1e-4)  # the right pairs: no error
    assert rows[str(peer)][0] == 0  # no stamp within 1 ms
    rows = _eval('--bag', bag, '--pair', 'index', peer)
    # The 9 reference poses give 8 RPE pairs 1 m of travel apart (0-1, 1-2, 2-5, 3-5, 4-5, 5-6, 6-8, 7-8): 2
    # with the last pose, each 0.3 m off; aligned at the first pose only the last is off, by 0.3 m.
    n, rpe_m, rpe_deg, rpe_rms_m, rpe_rms_deg, ate_fit, ate_first = rows[str(peer)]
    assert n == 9 and rpe_deg == 0 and rpe_rms_deg == 0
    assert rpe_m == pytest.approx(0.6 / 8, abs=1e-4) and rpe_rms_m == pytest.approx(math.sqrt(0.18 / 8), abs=1e-4)
    assert ate_first == pytest.approx(0.1, abs=1e-4) and 0 < ate_fit < 0.1
    # The run has 10 poses, the reference 9: by index, an error naming both.
    r = run('trajectory_eval', '--bag', bag, '--pair', 'index', peer, tum)
    assert_fails_cleanly(r, 'trajectory_eval', tmp_path, '%s has 10 poses, the reference (/ground_truth/odom in %s) 9'
                         % (tum, bag), left=['ref.bag', 'estimate.tum', 'peer.txt'])
    assert not r.stdout


def test_the_odometry_and_the_reference_are_written_as_trajectories(tmp_path):
    bag = _bag(tmp_path / 'ref.bag')
    odo, ref = tmp_path / 'odometry.tum', tmp_path / 'reference.tum'
    rows = _eval('--bag', bag, '--write-odometry', odo, '--write-reference', ref, odo, ref)
    t, xy, yaw = ev.read_trajectory(str(odo))
    assert np.allclose(t, T0 + PAIRING_REF_T)  # one pose per reference pose, at its stamp
    expected = np.array([_odometry_pose(s) for s in t])
    assert np.allclose(xy, expected[:, :2]) and np.allclose(yaw, expected[:, 2])
    t, xy, yaw = ev.read_trajectory(str(ref))
    assert np.allclose(t, T0 + PAIRING_REF_T) and np.allclose(np.column_stack([xy, yaw]), PAIRING_REF)
    assert rows[str(ref)] == pytest.approx([9, 0, 0, 0, 0, 0, 0], abs=1e-4)  # every pose with its own
    assert rows[str(odo)][0] == 9 and rows[str(odo)][5] > 0.1
    r = run('trajectory_eval', '--bag', bag, '--write-odometry', odo, '--odom', '/nope')
    assert_fails_cleanly(r, 'trajectory_eval', tmp_path, 'no nav_msgs/Odometry on /nope (the odometry)',
                         left=['ref.bag', 'odometry.tum', 'reference.tum'])


def test_poses_sharing_a_reference_pose_are_warned_of_once(tmp_path):
    """Coarse stamps: two poses near 1 s (1.0 and 1.0003 s) find the one reference pose there. Both stay paired
    (order-preserving), and one warning line gives the count."""
    bag = _bag(tmp_path / 'ref.bag')
    run_t = T0 + np.array([0.0, 1.0, 1.0003, 3.0, 5.0])
    coarse = tmp_path / 'coarse.tum'
    coarse.write_text(ev.tum_text(run_t, np.zeros((5, 2)), np.zeros(5)))
    r = run('trajectory_eval', '--bag', bag, coarse)
    assert r.returncode == 0
    assert r.stderr == ('trajectory_eval: warning: %s: 1 of 5 paired poses share their reference pose with another '
                        'pose (stamps coarser than the poses; --pair index pairs by order)\n' % coarse)
    assert _table(r.stdout)[str(coarse)][0] == 5


def test_a_file_in_neither_layout_is_one_line_naming_file_and_line(tmp_path):
    bag = _bag(tmp_path / 'ref.bag')
    bad = tmp_path / 'bad.txt'
    bad.write_text('100 0 0 0\n101 1 0\n')
    r = run('trajectory_eval', '--bag', bag, bad)
    assert_fails_cleanly(r, 'trajectory_eval', tmp_path, '%s:2: expected 4 columns (t x y theta)' % bad,
                         left=['ref.bag', 'bad.txt'])
    r = run('trajectory_eval', '--help')
    assert r.returncode == 0 and '--pair index' in r.stdout and 't x y theta' in r.stdout


def test_a_missing_figure_is_a_dash_as_wide_as_the_number():
    from rbpf_slam import trajectory_eval as te
    assert te._num(None, '%9.3f') == '        -' and te._num(1.5, '%9.3f') == '    1.500'
    assert te._num(None, '%10.4f') == ' ' * 9 + '-' and te._num(-0.25, '%10.4f') == '   -0.2500'
