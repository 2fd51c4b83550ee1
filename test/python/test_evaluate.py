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


def _moved(poses, frame):
    """Poses (n, 3) in another frame: the rigid motion frame = (x, y, yaw) applied to each."""
    return np.array([_compose(frame, p) for p in poses])


# A reference whose converter gave several scans one stamp (three at 2 s, two at 4 s), the poses sharing a
# stamp 30 degrees apart in heading; and a run with two poses at 2 s, three at 4 s, one at 1.0004 s (0.4 ms
# off), one at 3.5 s (no reference pose within 1 ms).
PAIRING_REF_T = np.array([0.0, 1.0, 2.0, 2.0, 2.0, 3.0, 4.0, 4.0, 5.0])
PAIRING_REF = np.array([(0.0, 0.0, 0.0), (1.0, 0.1, 0.0), (2.0, 0.3, 0.0), (2.02, 0.3, math.radians(30)),
                        (2.04, 0.3, math.radians(60)), (3.0, 0.6, 0.0), (4.0, 1.0, 0.0),
                        (4.02, 1.0, math.radians(30)), (5.0, 1.5, 0.0)])
PAIRING_RUN_T = np.array([0.0, 1.0004, 2.0, 2.0, 3.0, 3.5, 4.0, 4.0, 4.0, 5.0])
#: The right pairs: run pose -> reference pose (run poses 5 and 8 have none).
PAIRING_RIGHT = {0: 0, 1: 1, 2: 2, 3: 3, 4: 5, 6: 6, 7: 7, 9: 8}


def _pairing_run(frame=(3.0, -1.0, 0.4)):
    """The run: each paired pose the reference pose of its right partner in another frame, the unpaired
    ones far off (a wrong pairing would show)."""
    poses = np.full((len(PAIRING_RUN_T), 3), 50.0)
    for i, j in PAIRING_RIGHT.items():
        poses[i] = _compose(frame, PAIRING_REF[j])
    return poses


def test_stamp_pairing_keeps_file_order_for_equal_stamps_and_never_goes_back():
    i, j = ev.match_by_stamp(PAIRING_RUN_T, PAIRING_REF_T, 1e-3)
    assert list(zip(i.tolist(), j.tolist())) == sorted(PAIRING_RIGHT.items())
    # Monotone, also where the run's stamps go backwards: the pose stamped 1 s after one stamped 2 s gets no
    # earlier partner; it takes the previous pose's partner when that is within the tolerance, else none.
    ref_t = np.array([0.0, 1.0, 2.0, 3.0])
    i, j = ev.match_by_stamp([0.0, 2.0, 1.0, 3.0], ref_t, 1e-3)
    assert list(i) == [0, 1, 3] and list(j) == [0, 2, 3]
    i, j = ev.match_by_stamp([0.0, 2.0, 1.0, 3.0], ref_t, 1.5)
    assert list(i) == [0, 1, 2, 3] and list(j) == [0, 2, 2, 3]
    # A pose just after a run of equal stamps that all found partners keeps to the last of them.
    i, j = ev.match_by_stamp([2.0, 2.0, 2.0004], [2.0, 2.0, 3.0], 1e-3)
    assert list(i) == [0, 1, 2] and list(j) == [0, 1, 1]
    with pytest.raises(ValueError, match="reference's stamps go backwards at pose 3"):
        ev.match_by_stamp([0.0], [0.0, 2.0, 1.0], 1e-3)


def test_poses_on_one_reference_pose_are_counted():
    """Stamps coarser than the poses (a run stamped to the millisecond against a reference at 0.1 ms): two poses
    find the same reference pose. They stay paired (order-preserving), and are counted so that a tool warns."""
    ref_t = np.array([1.0, 1.0005, 2.0, 3.0])
    i, j = ev.match_by_stamp([1.0001, 1.0002, 2.0, 3.0], ref_t, 1e-3)
    assert list(j) == [0, 0, 2, 3] and ev.shared_partners(j) == 1
    assert ev.shared_partners(ev.match_by_stamp(PAIRING_RUN_T, PAIRING_REF_T, 1e-3)[1]) == 0
    xy = np.column_stack([np.arange(4.0), np.zeros(4)])
    e = ev.trajectory_errors((np.array([1.0001, 1.0002, 2.0, 3.0]), xy, np.zeros(4)), (ref_t, xy, np.zeros(4)))
    assert e['poses'] == 4 and e['shared_partners'] == 1
    e = ev.trajectory_errors((ref_t, xy, np.zeros(4)), (ref_t, xy, np.zeros(4)))
    assert e['shared_partners'] == 0


def test_tum_stamps_keep_the_nanoseconds(tmp_path):
    """A Unix stamp written to a TUM file and read back within 1 us (12 significant digits kept 10 ms); the
    other columns as before."""
    t = np.array([1700000000.123456789, 1700000000.123458, 12.5])
    text = ev.tum_text(t, [(1.25, -2.0), (0.1, 0.2), (3.0, 4.0)], [0.5, 0.0, -1.0])
    assert text.splitlines()[0].split()[0] == ev.format_stamp(t[0]) == '%.9f' % t[0]
    assert text.splitlines()[2].split()[:3] == ['12.500000000', '3', '4']
    path = tmp_path / 'run.tum'
    path.write_text(text)
    back, xy, yaw = ev.read_tum(str(path))
    assert np.max(np.abs(back - t)) < 1e-6 and back[1] - back[0] == pytest.approx(1.2e-6, abs=1e-6)
    np.testing.assert_allclose(yaw, [0.5, 0.0, -1.0], atol=1e-11)


def test_trajectory_errors_of_a_run_with_equal_stamps_are_those_of_the_right_pairs():
    ref = (PAIRING_REF_T, PAIRING_REF[:, :2], PAIRING_REF[:, 2])
    poses = _pairing_run()
    e = ev.trajectory_errors((PAIRING_RUN_T, poses[:, :2], poses[:, 2]), ref, travel=1.0, tolerance=1e-3)
    # A perfect run in another frame: every figure is zero.
    assert e['poses'] == 8 and e['rpe_pairs'] == 7
    for key in ('ate', 'ate_first_pose', 'rpe_translation_rms', 'rpe_rotation_rms_deg'):
        assert e[key] == pytest.approx(0.0, abs=1e-9), key
    # The last pose 0.3 m off: it is in 2 of the 7 RPE pairs (the paired reference poses 1 m of travel
    # apart: 0-1, 1-2, 2-5, 3-5, 5-6, 6-8, 7-8), whose translation error is then 0.3 m; aligned at the first
    # pose, its error is 0.3 m and the others' none.
    poses[9, :2] += [0.0, 0.3]
    e = ev.trajectory_errors((PAIRING_RUN_T, poses[:, :2], poses[:, 2]), ref, travel=1.0, tolerance=1e-3)
    assert e['rpe_translation_mean'] == pytest.approx(0.6 / 7)
    assert e['rpe_translation_rms'] == pytest.approx(math.sqrt(2 * 0.09 / 7))
    assert e['rpe_rotation_rms_deg'] == pytest.approx(0.0, abs=1e-9)
    assert e['ate_first_pose'] == pytest.approx(0.3 / math.sqrt(8))
    assert 0.0 < e['ate'] < 0.3


def test_ate_after_the_fit_and_aligned_at_the_first_pose_have_known_values():
    # Four poses on the unit circle, the run 10 % larger and in another frame. The fit takes out the frame
    # and nothing else (by symmetry): 0.1 m. Aligned at the first pose (1.1, 0) -> (1, 0) the run is only
    # shifted by -0.1 m in x: errors 0, 0.1 sqrt 2, 0.2, 0.1 sqrt 2, RMS sqrt(0.02).
    angles = np.radians([0.0, 90.0, 180.0, 270.0])
    ref = np.column_stack([np.cos(angles), np.sin(angles), angles + math.pi / 2])
    run = _moved(np.column_stack([1.1 * ref[:, :2], ref[:, 2]]), (2.0, -3.0, 0.7))
    t = np.arange(4.0)
    e = ev.trajectory_errors((t, run[:, :2], run[:, 2]), (t, ref[:, :2], ref[:, 2]), pair='index')
    assert e['ate'] == pytest.approx(0.1)
    assert e['ate_first_pose'] == pytest.approx(math.sqrt(0.02))
    assert ev.first_pose_rmse(run[:, :2], run[:, 2], ref[:, :2], ref[:, 2]) == pytest.approx(math.sqrt(0.02))
    # The run's positions exact, its first heading 0.1 rad off: the fit sees no error; aligned at the first
    # pose the path turns by -0.1 rad about its start, pose k (k metres out) 2 sin(0.05) k off.
    k = np.arange(11.0)
    ref = np.column_stack([k, np.zeros(11), np.zeros(11)])
    yaw = np.zeros(11)
    yaw[0] = 0.1
    e = ev.trajectory_errors((k, ref[:, :2], yaw), (k, ref[:, :2], ref[:, 2]))
    assert e['ate'] == pytest.approx(0.0, abs=1e-9)
    assert e['ate_first_pose'] == pytest.approx(2 * math.sin(0.05) * math.sqrt(np.mean(k ** 2)))
    # A reference of positions only has no first-pose heading.
    assert ev.trajectory_errors((k, ref[:, :2], yaw), (k, ref[:, :2], None))['ate_first_pose'] is None


def test_index_pairing_takes_the_kth_pose_with_the_kth_and_needs_as_many():
    t = np.arange(5.0)
    ref = (t, np.column_stack([t, np.zeros(5)]), np.zeros(5))
    run = (t + 0.3, ref[1] + [1.0, 2.0], ref[2])  # stamps of another clock, another frame
    assert ev.trajectory_errors(run, ref)['poses'] == 0
    e = ev.trajectory_errors(run, ref, pair='index')
    assert e['poses'] == 5 and e['ate'] == pytest.approx(0.0, abs=1e-12)
    with pytest.raises(ValueError, match='4 poses against 5 reference poses'):
        ev.trajectory_errors(tuple(v[:4] for v in run), ref, pair='index')


def test_trajectory_files_in_either_layout_read_the_same(tmp_path):
    t, yaw = np.array([10.0, 10.5, 10.5]), np.array([3.0, -1.5, 0.2])
    xy = np.array([[1.0, -2.0], [3.25, 0.5], [3.5, 0.5]])
    tum = tmp_path / 'estimate.tum'
    tum.write_text('# t x y z qx qy qz qw\n' + ev.tum_text(t, xy, yaw))
    peer = tmp_path / 'peer.txt'
    peer.write_text(''.join('%.6f %.6f %.6f %.6f\n' % (ti, p[0], p[1], a) for ti, p, a in zip(t, xy, yaw)) + '\n')
    for path in (tum, peer):
        rt, rxy, ryaw = ev.read_trajectory(str(path))
        assert np.allclose(rt, t) and np.allclose(rxy, xy) and np.allclose(ryaw, yaw), path


@pytest.mark.parametrize('text, message', [
    ('0 1 2\n', ':1: expected 8 (TUM: t x y z qx qy qz qw) or 4 (t x y theta) columns, got 3'),
    ('image: map.pgm\n', ':1: expected 8 (TUM: t x y z qx qy qz qw) or 4 (t x y theta) columns, got 2'),
    ('# header\n0 1 2 3\n1 1 2 3 0 0 0 1\n', ':3: expected 4 columns (t x y theta) as on the first pose line, got 8'),
    ('0 1 2 3\n1 1 y 3\n', ":2: expected 4 finite numbers (t x y theta), got '1 1 y 3'"),
    ('0 1 2 nan\n', ":1: expected 4 finite numbers (t x y theta), got '0 1 2 nan'"),
    ('# nothing\n\n', ': empty trajectory, expected lines of 8 (TUM: t x y z qx qy qz qw) or 4 (t x y theta) columns'),
])
def test_a_trajectory_file_in_neither_layout_is_an_error_naming_file_and_line(tmp_path, text, message):
    path = tmp_path / 'x.txt'
    path.write_text(text)
    with pytest.raises(ValueError) as e:
        ev.read_trajectory(str(path))
    assert str(e.value) == str(path) + message


def test_a_binary_file_is_no_trajectory(tmp_path):
    path = tmp_path / 'map.pgm'
    path.write_bytes(b'P5\n2 2\n255\n\xff\xfe\x80\x00')
    with pytest.raises(ValueError, match='map.pgm: not a text file'):
        ev.read_trajectory(str(path))


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


def test_tree_map_file_with_anchor_covariance_and_times(tmp_path):
    path = tmp_path / 'forest_map.csv'
    path.write_text('# anchor: latitude=61.5 longitude=24.25 altitude=110 yaw=0.3 sigma=0.8\n'
                    'id,x,y,dbh,sigma_x,sigma_y,sigma_dbh,observations,provisional,cov_xy,first_seen,last_seen\n'
                    '3,1.5,-2.0,0.30,0.02,0.03,0.02,12,0,0.0001,100.5,200.25\n'
                    '# a comment between trees\n'
                    '4,5.0,5.0,0.10,0.10,0.10,0.05,1,1,0,,\n')
    m = ev.read_landmarks_csv(str(path))
    assert m['anchor'] == {'latitude': 61.5, 'longitude': 24.25, 'altitude': 110.0, 'yaw': 0.3, 'sigma': 0.8}
    assert list(m['id']) == [3, 4]
    assert m['cov_xy'] == pytest.approx([0.0001, 0.0])
    assert m['first_seen'][0] == 100.5 and m['last_seen'][0] == 200.25
    assert np.isnan(m['first_seen'][1]) and np.isnan(m['last_seen'][1])
    path.write_text('id,x,y,dbh,sigma_x,sigma_y,sigma_dbh,observations,provisional\n# note\n'
                    '1,x,2,0.2,0,0,0,1,0\n')
    with pytest.raises(ValueError, match='forest_map.csv:3: expected 9 numbers'):
        ev.read_landmarks_csv(str(path))
