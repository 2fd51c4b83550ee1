"""The bag-run evaluator (src/rbpf_slam/evaluate.py) on synthetic paths and maps whose answer is known."""
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'src'))
from rbpf_slam import evaluate as ev  # noqa: E402


def _rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def test_rigid_fit_recovers_a_known_transform():
    rng = np.random.default_rng(1)
    src = rng.uniform(-3, 3, size=(50, 2))
    dst = src @ _rot(0.7).T + np.array([1.5, -2.0])
    r, t = ev.fit_rigid_2d(src, dst)
    assert np.allclose(r, _rot(0.7), atol=1e-9)
    assert np.allclose(t, [1.5, -2.0], atol=1e-9)


def test_map_score_counts_matches_duplicates_and_spurious():
    trees = np.array([[0, 0, 0.2], [5, 0, 0.3], [0, 5, 0.1]], float)
    feats = np.array([[0.05, 0, 0.21],   # tree 0
                      [0.7, 0.1, 0.2],    # a second feature 0.7 m from matched tree 0: duplicate
                      [5, 0.02, 0.28],    # tree 1
                      [9, 9, 0.2],        # nothing near: spurious
                      [0, 5.8, 0.1]],     # 0.8 m from tree 2, which nothing matched: spurious, not duplicate
                     float)
    s = ev.score_map(feats, trees, gate=0.5)
    assert s['matched'] == 2 and s['duplicates'] == 1 and s['spurious'] == 2
    assert s['recall'] == pytest.approx(2 / 3)
    assert s['mean_error'] == pytest.approx((0.05 + 0.02) / 2)


def test_evaluate_fits_a_rotated_run_and_reports_the_odometry_beside_it():
    t = np.linspace(0, 10, 101)
    truth = np.column_stack([t, np.sin(t)])
    yaw = np.arctan2(np.cos(t), np.ones_like(t))
    # The estimate is the truth in another frame (rotated, shifted): after the fit its error is zero.
    est_xy = truth @ _rot(-0.4).T + np.array([0.3, 0.2])
    est = (t, est_xy, yaw - 0.4)
    odo = (t, truth * 1.1, yaw)
    tree = np.array([[1.0, 1.0, 0.1]])
    feature = np.r_[_rot(-0.4) @ tree[0, :2] + [0.3, 0.2], 0.1][None, :]  # the tree in the estimate's frame
    s, _, _ = ev.evaluate(est, odo, t, truth, None, tree, feature)
    assert s['estimate']['path_rms'] < 1e-9
    assert s['odometry']['path_rms'] > 0.05
    assert s['map']['matched'] == 1 and s['map']['mean_error'] < 1e-9
    # Without the fit the frame difference shows.
    s2, _, _ = ev.evaluate(est, odo, t, truth, fit=False)
    assert s2['estimate']['path_rms'] > 0.2


def test_rpe_is_zero_for_the_same_path_and_sees_a_scale_error():
    t = np.linspace(0, 20, 201)
    xy = np.column_stack([t, np.zeros_like(t)])
    assert ev.rpe(xy, xy, 1.0)[0] == pytest.approx(0.0)
    trans, _, pairs = ev.rpe(xy, 1.05 * xy, 1.0)
    assert pairs > 100 and trans == pytest.approx(0.05, rel=0.05)


def test_point_offset_moves_along_the_heading():
    p = ev.point_of(np.array([[1.0, 2.0]]), np.array([math.pi / 2]), (0.03, 0.0))
    assert np.allclose(p, [[1.0, 2.03]])


def test_a_malformed_trajectory_is_an_error_naming_the_file(tmp_path):
    path = tmp_path / 'map.yaml'
    path.write_text('image: map.pgm\nresolution: 0.05\n')
    with pytest.raises(ValueError, match='map.yaml: not a TUM trajectory'):
        ev.read_tum(str(path))
    path.write_text('0 1 2\n')
    with pytest.raises(ValueError, match='map.yaml: expected 8 columns'):
        ev.read_tum(str(path))


def test_no_overlap_is_a_clear_error():
    t = np.linspace(0, 1, 5)
    xy = np.zeros((5, 2))
    with pytest.raises(ValueError, match='does not overlap'):
        ev.evaluate((t + 10, xy, np.zeros(5)), None, t, xy)


def test_similarity_fit_recovers_scale():
    rng = np.random.default_rng(2)
    src = rng.uniform(-3, 3, size=(40, 2))
    dst = 0.93 * src @ _rot(-1.1).T + np.array([0.5, 4.0])
    scale, r, t = ev.fit_similarity_2d(src, dst)
    assert scale == pytest.approx(0.93) and np.allclose(r, _rot(-1.1)) and np.allclose(t, [0.5, 4.0])


def _compose(a, b):
    """SE(2) a * b of (x, y, yaw) tuples."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def test_ate_after_the_rigid_fit_removes_a_frame_but_not_an_error():
    ref = np.array([(0.1 * i, math.sin(0.2 * i)) for i in range(50)])
    est = (ref - [2.0, -1.0]) @ _rot(-0.7).T  # the reference in another frame
    assert ev.aligned_rmse(est, ref) == pytest.approx(0.0, abs=1e-9)
    assert np.sqrt(np.mean(np.sum((est - ref) ** 2, axis=1))) > 1.0  # without the fit
    # One point 1 m off: the fit cannot remove it, and does no worse than the true transform.
    est[10, 0] += 1.0
    assert 0.1 < ev.aligned_rmse(est, ref) < 1.0 / math.sqrt(50.0) + 1e-9


def test_rpe_over_one_metre_of_travel_sees_a_turn_rate_and_a_scale_error():
    # Straight line at 0.125 m per pose; the estimate turns 1 degree per metre more than the reference and
    # is 2 % long: over each 1 m pair the rotation error is 1 degree, the translation error about 0.02 m.
    ref = np.array([(0.125 * i, 0.0, 0.0) for i in range(101)])
    est = [(0.0, 0.0, 0.0)]
    for _ in range(100):
        est.append(_compose(est[-1], (0.1275, 0.0, math.radians(0.125))))
    trans, rot = ev.relative_pose_errors(np.array(est), ref, 1.0)
    assert len(trans) == 93  # pose i pairs with i + 8 (the first at >= 1 m of travel)
    assert np.mean(rot) == pytest.approx(1.0, abs=1e-9)
    assert np.mean(trans) == pytest.approx(0.02, abs=0.005)
    assert np.sqrt(np.mean(trans ** 2)) >= np.mean(trans)
    # A rigidly moved copy has no relative error at all.
    moved = np.array([_compose((5.0, 5.0, 1.0), p) for p in ref])
    trans, rot = ev.relative_pose_errors(moved, ref, 1.0)
    assert np.max(trans) == pytest.approx(0.0, abs=1e-12) and np.max(rot) == pytest.approx(0.0, abs=1e-9)


def test_stamps_match_the_nearest_reference_within_the_tolerance():
    ref_t = np.array([0.0, 1.0, 2.0, 3.0])
    i, j = ev.match_by_stamp([0.0004, 0.5, 1.9995, 2.5, 3.0008, 9.0], ref_t, 1e-3)
    assert list(i) == [0, 2, 4] and list(j) == [0, 2, 3]
    i, j = ev.match_by_stamp([0.5, 2.5], ref_t, 0.6)  # a tie goes to the later reference pose
    assert list(j) == [1, 3]


def test_trajectory_errors_pair_by_stamp_and_fit_the_frame():
    t = np.arange(0.0, 20.0, 0.1)
    ref = (t, np.column_stack([t, np.sin(t)]), np.arctan2(np.cos(t), np.ones_like(t)))
    # Every other pose, in another frame: a perfect run.
    run = (t[::2], ref[1][::2] @ _rot(0.3).T + [1.0, 2.0], ref[2][::2] + 0.3)
    e = ev.trajectory_errors(run, ref, travel=1.0, tolerance=1e-3)
    assert e['poses'] == 100 and e['rpe_pairs'] > 50
    assert e['ate'] == pytest.approx(0.0, abs=1e-9)
    assert e['rpe_translation_mean'] == pytest.approx(0.0, abs=1e-9)
    assert e['rpe_rotation_rms_deg'] == pytest.approx(0.0, abs=1e-6)
    # Stamps 5 ms late match nothing within 1 ms; a reference without headings has no rotation error.
    late = ev.trajectory_errors((run[0] + 0.005,) + run[1:], ref, tolerance=1e-3)
    assert late['poses'] == 0 and math.isnan(late['ate'])
    e = ev.trajectory_errors(run, ref[:2] + (None,))
    assert e['rpe_rotation_mean_deg'] is None and e['ate'] == pytest.approx(0.0, abs=1e-9)


def test_tum_text_reads_back():
    t, xy, yaw = np.array([10.0, 10.5]), np.array([[1.0, -2.0], [3.25, 0.5]]), np.array([3.0, -1.5])
    text = ev.tum_text(t, xy, yaw)
    assert text.splitlines()[0].split()[3:6] == ['0', '0', '0']
    data = np.loadtxt(text.splitlines(), ndmin=2)
    from rbpf_slam.geometry import yaw_of
    assert np.allclose(data[:, 0], t) and np.allclose(data[:, 1:3], xy) and np.allclose(yaw_of(data[:, 4:8]), yaw)


def test_landmark_csv_reads_the_inventory_columns(tmp_path):
    path = tmp_path / 'map.csv'
    path.write_text('id,x,y,dbh,sigma_x,sigma_y,sigma_dbh,observations,provisional\n'
                    '3,1.5,-2.0,0.30,0.02,0.03,0.02,12,0\n'
                    '4,5.0,5.0,0.10,0.10,0.10,0.05,1,1\n')
    m = ev.read_landmarks_csv(str(path))
    assert list(m['id']) == [3, 4] and list(m['observations']) == [12, 1]
    assert list(m['provisional']) == [False, True]
    assert m['radius'] == pytest.approx([0.15, 0.05]) and m['sigma_dbh'] == pytest.approx([0.02, 0.05])
    assert ev.read_map_csv(str(path)).tolist() == [[1.5, -2.0, 0.15]]
    assert ev.read_map_csv(str(path), include_provisional=True).shape == (2, 3)
    path.write_text(','.join(ev.LANDMARK_COLUMNS) + '\n')
    assert ev.read_map_csv(str(path)).shape == (0, 3)  # a map without trees


def test_landmark_csv_errors_name_the_file_and_line(tmp_path):
    old = tmp_path / 'old.csv'  # the columns of an earlier map.csv: radius instead of dbh
    old.write_text('id,x,y,radius,sigma_x,sigma_y,sigma_radius,observations,provisional\n0,1,2,0.1,0,0,0,1,0\n')
    with pytest.raises(ValueError, match='old.csv: not a landmark CSV: no column dbh, sigma_dbh'):
        ev.read_landmarks_csv(str(old))
    bad = tmp_path / 'bad.csv'
    bad.write_text(','.join(ev.LANDMARK_COLUMNS) + '\n0,1,2,0.2,0,0,0,1,0\n1,x,2,0.2,0,0,0,1,0\n')
    with pytest.raises(ValueError, match='bad.csv:3: expected 9 numbers'):
        ev.read_landmarks_csv(str(bad))
    empty = tmp_path / 'empty.csv'
    empty.write_text('')
    with pytest.raises(ValueError, match='empty.csv: empty'):
        ev.read_landmarks_csv(str(empty))
