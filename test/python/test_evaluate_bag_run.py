"""evaluate_bag_run on small synthetic bags whose answer is known: a GPS reference (PointStamped in a local
metric frame, NavSatFix in latitude / longitude), a map scored alone, the simulator's /ground_truth/trees, the
figures with and without a fit, and bad input."""
import json
import math
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'src'))
from rbpf_slam import evaluate as ev  # noqa: E402
from test_converter_faults import assert_fails_cleanly, run  # noqa: E402

rosbag = pytest.importorskip('rosbag')
pytest.importorskip('rbpf_slam.msg')
from geometry_msgs.msg import PointStamped  # noqa: E402
from rbpf_slam import convert_msgs as cm  # noqa: E402
from rbpf_slam.msg import Trunk, TrunkArray  # noqa: E402
from sensor_msgs.msg import NavSatFix  # noqa: E402

TREES = np.array([[3.0, 3.0, 0.20], [8.0, -3.0, 0.15], [12.0, 4.0, 0.30], [16.0, -2.0, 0.10], [20.0, 3.0, 0.25]])


def _rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def _path(t0=100.0, seconds=20.0):
    """A 20 s drive at 1 m/s along a gentle S (t, xy, yaw), 10 Hz."""
    t = np.arange(0.0, seconds + 1e-9, 0.1)
    xy = np.column_stack([t, 2.0 * np.sin(0.3 * t)])
    return t0 + t, xy, np.arctan2(0.6 * np.cos(0.3 * t), np.ones_like(t))


def _run_dir(tmp_path, est, odo=None, features=None):
    d = tmp_path / 'run'
    d.mkdir()
    (d / 'estimate.tum').write_text(ev.tum_text(*est))
    if odo is not None:
        (d / 'odometry.tum').write_text(ev.tum_text(*odo))
    if features is not None:
        rows = ['%d,%.9f,%.9f,%.9f,0.01,0.01,0.01,5,0' % (i, f[0], f[1], 2 * f[2]) for i, f in enumerate(features)]
        (d / 'map.csv').write_text('\n'.join([','.join(ev.LANDMARK_COLUMNS)] + rows) + '\n')
    return d


def _trunks(trees, stamp, frame='map'):
    return TrunkArray(header=cm.header(stamp, frame),
                      trunks=[Trunk(center=cm.Point(x, y, 1.3), radius=r) for x, y, r in trees])


def _bag(path, odom=None, points=None, fixes=None, landmarks=None, landmarks_topic='/ground_truth/trees',
         points_topic='/gps', fix_topic='/gps/fix'):
    """A bag of reference topics: odom (t, xy, yaw) on /ground_truth/odom, points (t, xy) as PointStamped,
    fixes [(t, lat, lon, status)] as NavSatFix, landmarks (m, 3) as one latched-style TrunkArray first."""
    with rosbag.Bag(str(path), 'w') as bag:
        if landmarks is not None:
            bag.write(landmarks_topic, _trunks(landmarks, 1.0), cm.ros_time(1.0))
        if odom is not None:
            for ti, p, a in zip(*odom):
                bag.write('/ground_truth/odom', cm.odometry(ti, 'map', 'base_link', p[0], p[1], a), cm.ros_time(ti))
        if points is not None:
            for ti, p in zip(*points):
                msg = PointStamped(header=cm.header(ti, 'gps'))
                msg.point.x, msg.point.y = p
                bag.write(points_topic, msg, cm.ros_time(ti))
        if fixes is not None:
            for ti, lat, lon, status in fixes:
                msg = NavSatFix(header=cm.header(ti, 'gps'), latitude=lat, longitude=lon, altitude=500.0)
                msg.status.status = status
                bag.write(fix_topic, msg, cm.ros_time(ti))
    return str(path)


def _evaluate(bag, run_dir, *args):
    r = run('evaluate_bag_run', '--bag', bag, '--run', run_dir, '--no-plot', *args)
    assert r.returncode == 0 and 'Traceback' not in r.stderr, r.stderr
    with open(os.path.join(str(run_dir), 'evaluation.json')) as f:
        return r.stdout, json.load(f)


def test_point_stamped_gps_after_the_fit_has_no_error_and_counts_the_fixes_inside_the_run(tmp_path):
    est = _path()
    # 1 Hz fixes from 5 s before the run to 5 s after it: 21 of 31 inside the estimate's time span.
    t = np.arange(95.0, 125.5, 1.0)
    xy = np.column_stack([t - 100.0, 2.0 * np.sin(0.3 * (t - 100.0))])
    gps = (t, xy @ _rot(0.5).T + [10.0, -5.0])  # the same path in the GPS frame
    bag = _bag(tmp_path / 'gps.bag', points=(gps[0], gps[1]))
    out, s = _evaluate(bag, _run_dir(tmp_path, est, odo=(est[0], 1.02 * est[1], est[2])))
    assert 'reference: /gps (geometry_msgs/PointStamped' in out
    assert '21 of 31 reference fixes inside' in out
    assert s['reference']['topic'] == '/gps' and s['reference_poses'] == 21 and s['reference_total'] == 31
    assert s['estimate']['path_rms'] == pytest.approx(0.0, abs=1e-6)
    assert s['estimate']['transform']['rotation_deg'] == pytest.approx(math.degrees(0.5), abs=1e-6)
    assert s['estimate']['transform']['translation'] == pytest.approx([10.0, -5.0], abs=1e-6)
    assert s['odometry']['path_rms'] > 0.05
    assert s['estimate']['rpe_rotation_deg'] is None  # positions only
    assert s['no_fit']['estimate']['path_rms'] > 5.0  # the GPS frame is not the run's
    assert 'map' not in s and 'the map is not scored' in out


def _latlon(east, north, lat0, lon0):
    """Latitude / longitude of a local east / north offset by the radii of curvature of the WGS84 ellipsoid
    at (lat0, lon0) (independent of the evaluator's conversion through ECEF; within millimetres over 100 m)."""
    a, f = 6378137.0, 1.0 / 298.257223563
    e2 = f * (2.0 - f)
    phi = math.radians(lat0)
    w = 1.0 - e2 * math.sin(phi) ** 2
    meridian, normal = a * (1.0 - e2) / w ** 1.5, a / math.sqrt(w)
    return lat0 + math.degrees(north / meridian), lon0 + math.degrees(east / (normal * math.cos(phi)))


def test_navsatfix_becomes_metres_in_a_local_enu_frame_and_invalid_fixes_are_skipped(tmp_path):
    lat0, lon0 = 48.137, 11.575
    # A 100 m square, 5 m per fix at 1 Hz, starting at the first fix.
    side = np.arange(0.0, 100.0, 5.0)
    zeros, hundreds = np.zeros_like(side), np.full_like(side, 100.0)
    square = np.vstack([np.column_stack([side, zeros]), np.column_stack([hundreds, side]),
                        np.column_stack([100.0 - side, hundreds]), np.column_stack([zeros, 100.0 - side]),
                        [[0.0, 0.0]]])
    fixes = [(10.0 + k, ) + _latlon(e, n, lat0, lon0) + (0,) for k, (e, n) in enumerate(square)]
    fixes.insert(7, (16.5, lat0 + 0.01, lon0, -1))  # NO_FIX: skipped
    fixes.insert(20, (28.5, float('nan'), lon0, 0))  # not finite: skipped
    bag = _bag(tmp_path / 'fix.bag', fixes=fixes)
    ref = ev.read_bag_reference(bag)
    assert ref['topic'] == '/gps/fix' and ref['yaw'] is None
    assert ref['messages'] == len(square) + 2 and ref['skipped'] == 2
    assert ref['origin'] == pytest.approx((lat0, lon0))
    assert np.abs(ref['xy'] - square).max() < 0.01
    steps = np.linalg.norm(np.diff(ref['xy'], axis=0), axis=1)
    assert steps == pytest.approx(5.0, abs=0.01)
    assert np.linalg.norm(ref['xy'][20] - ref['xy'][0]) == pytest.approx(100.0, abs=0.01)
    assert np.linalg.norm(ref['xy'][40] - ref['xy'][0]) == pytest.approx(100.0 * math.sqrt(2.0), abs=0.01)
    # The run drove the square in its own frame (started heading north): after the fit the ATE is 0.
    t = 10.0 + np.arange(len(square), dtype=float)
    est = (t, square @ _rot(-math.pi / 2).T, np.zeros(len(t)))
    out, s = _evaluate(bag, _run_dir(tmp_path, est))
    assert 'sensor_msgs/NavSatFix' in out and '2 of %d skipped (no fix or not finite)' % (len(square) + 2) in out
    assert '%d of %d reference fixes' % (len(square), len(square)) in out
    assert s['estimate']['path_rms'] < 0.01
    assert s['reference']['skipped'] == 2 and s['reference']['origin_lat_lon'] == pytest.approx([lat0, lon0])


def test_enu_conversion_against_known_arc_lengths():
    # 0.001 deg of latitude at 45 deg: 111131.75 m per degree (the meridian arc series), 0.001 deg of longitude
    # on the equator: the semi-major axis times the angle.
    xy = ev.geodetic_to_enu([45.0005], [7.0], 44.9995, 7.0)
    assert xy[0] == pytest.approx([0.0, 111.13175], abs=0.01)
    xy = ev.geodetic_to_enu([0.0], [0.0010], 0.0, 0.0)
    assert xy[0] == pytest.approx([6378137.0 * math.radians(0.001), 0.0], abs=0.001)


def test_a_map_alone_is_fitted_onto_the_true_landmarks_and_counted(tmp_path):
    # The map in a frame 0.8 m, -0.3 m and 5 deg off; tree 4 not found, a duplicate of tree 0 0.7 m from it,
    # a spurious feature far from every tree; small errors on the rest.
    noise = np.array([[0.02, 0.0], [0.0, -0.03], [-0.02, 0.01], [0.01, 0.02]])
    found = np.column_stack([TREES[:4, :2] + noise, TREES[:4, 2]])
    extra = np.array([[3.7, 3.0, 0.2], [10.0, 12.0, 0.2]])
    feats = np.vstack([found, extra])
    r = _rot(math.radians(5.0))
    feats[:, :2] = (feats[:, :2] - [0.8, -0.3]) @ r  # so that R feats + (0.8, -0.3) is the truth frame
    bag = _bag(tmp_path / 'map.bag', landmarks=TREES, landmarks_topic='/ground_truth/landmarks')
    out, s = _evaluate(bag, _run_dir(tmp_path, _path(), features=feats))
    assert 'the map is scored alone' in out and 'fitted onto the true landmarks by a rigid fit over its' in out
    m = s['map']
    assert (m['trees'], m['features'], m['matched'], m['duplicates'], m['spurious']) == (5, 6, 4, 1, 1)
    assert m['recall'] == pytest.approx(0.8) and m['max_error'] < 0.05
    assert s['fit'] == 'map_rigid_2d' and s['map_fit']['matches'] == 4
    assert s['map_fit']['rotation_deg'] == pytest.approx(5.0, abs=0.5)
    assert s['no_fit']['map']['matched'] < 4  # the frame's offset is larger than the gate
    assert 'estimate' not in s


def _landmark_field(n=15, seed=4):
    """n landmarks scattered over 10 x 8 m (as MR.CLAM's 15 poles), no two closer than 1.5 m."""
    rng = np.random.RandomState(seed)
    pts = []
    while len(pts) < n:
        p = rng.uniform([0.0, 0.0], [10.0, 8.0])
        if all(np.hypot(*(p - q)) > 1.5 for q in pts):
            pts.append(p)
    return np.column_stack([np.array(pts), np.full(n, 0.1)])


def test_a_map_far_from_the_truths_frame_is_found_and_scored_whole():
    # A perfect map (5 cm of noise) in a frame turned 115 deg and moved 580 m: a fit from the identity finds
    # nothing; the search over pairs of landmarks finds the transform and all 15 match.
    truth = _landmark_field()
    rng = np.random.RandomState(1)
    noisy = truth[:, :2] + rng.normal(0.0, 0.05, (15, 2))
    r = _rot(math.radians(115.0))
    t = np.array([500.0, -300.0])
    feats = np.column_stack([(noisy - t) @ r, truth[:, 2]])  # R feats + t is the truth's frame
    s, _, _ = ev.evaluate(_path(), None, None, None, truth_map=truth, features=feats, no_fit_too=True)
    assert s['fit'] == 'map_rigid_2d' and s['map_fit']['matches'] == 15 and 'refused' not in s['map_fit']
    assert s['map_fit']['rotation_deg'] == pytest.approx(115.0, abs=1.0)
    # 580 m from the map's origin a tenth of a degree is decimetres: the translation is known to that.
    assert s['map_fit']['translation'] == pytest.approx([500.0, -300.0], abs=2.0)
    m = s['map']
    assert (m['matched'], m['duplicates'], m['spurious'], m['recall']) == (15, 0, 0, 1.0)
    assert m['rms_error'] < 0.1
    assert s['no_fit']['map']['matched'] == 0


def test_a_fit_over_fewer_than_three_matches_is_refused(tmp_path):
    # Two features: any two points fit any two points, which would read as a perfect score.
    d01 = float(np.hypot(*(TREES[0, :2] - TREES[1, :2])))
    feats = np.array([[100.0, 100.0, 0.2], [100.0 + d01, 100.0, 0.15]])  # as far apart as trees 0 and 1
    s, _, _ = ev.evaluate(_path(), None, None, None, truth_map=TREES, features=feats, no_fit_too=True)
    assert s['fit'] == 'none' and s['map_fit']['refused'] and s['map_fit']['matches'] == 2
    assert s['map']['matched'] == 0  # scored in its own frame, far from the truth
    bag = _bag(tmp_path / 'two.bag', landmarks=TREES, landmarks_topic='/ground_truth/landmarks')
    out, _ = _evaluate(bag, _run_dir(tmp_path, _path(), features=feats))
    assert 'under no rigid transform do 3 map features match a true landmark (2 at most): no fit' in out, out


def test_known_ids_tell_a_symmetric_field_apart():
    # Four landmarks on a square: four rotations fit equally well; the ids (known association) tell which.
    square = np.array([[0.0, 0.0, 0.1], [4.0, 0.0, 0.1], [4.0, 4.0, 0.1], [0.0, 4.0, 0.1]])
    ids = np.array([7, 8, 9, 10])
    r = _rot(math.radians(30.0))
    t = np.array([100.0, 50.0])
    feats = np.column_stack([(square[:, :2] - t) @ r, square[:, 2]])
    s, _, _ = ev.evaluate(_path(), None, None, None, truth_map=square, features=feats[::-1],
                          feature_ids=ids[::-1], truth_ids=ids)
    assert s['map_fit']['matches'] == 4
    assert s['map_fit']['rotation_deg'] == pytest.approx(30.0, abs=1e-6)
    assert s['map_fit']['translation'] == pytest.approx([100.0, 50.0], abs=1e-6)


def test_the_simulators_ground_truth_trees_are_the_true_landmarks(tmp_path):
    est = _path()
    feats = np.vstack([TREES + [0.05, 0.0, 0.01], [[10.0, 12.0, 0.2]]])
    bag = _bag(tmp_path / 'forest.bag', odom=est, landmarks=TREES)
    out, s = _evaluate(bag, _run_dir(tmp_path, est, features=feats))
    assert 'true landmarks: /ground_truth/trees, 5 in frame map' in out
    assert s['reference']['landmarks_topic'] == '/ground_truth/trees'
    assert s['reference_poses'] == len(est[0]) and s['estimate']['rpe_rotation_deg'] is not None
    assert (s['map']['matched'], s['map']['spurious'], s['map']['recall']) == (5, 1, 1.0)
    assert s['map']['mean_error'] == pytest.approx(0.05, abs=1e-6)
    # Without the landmark topic: one line says so, the path is still scored.
    os.remove(os.path.join(str(tmp_path / 'run'), 'evaluation.json'))
    out, s = _evaluate(_bag(tmp_path / 'odom.bag', odom=est), tmp_path / 'run')
    lines = [l for l in out.splitlines() if 'the map is not scored' in l]
    assert len(lines) == 1 and '/ground_truth/trees' in lines[0] and 'map' not in s


def test_the_figure_without_a_fit_is_printed_beside_the_fitted_one(tmp_path):
    est = _path()
    shifted = (est[0], est[1] @ _rot(0.1).T + [0.5, 0.2], est[2] + 0.1)  # the run started off the true pose
    feats = np.column_stack([TREES[:, :2] @ _rot(0.1).T + [0.5, 0.2], TREES[:, 2]])
    bag = _bag(tmp_path / 'forest.bag', odom=est, landmarks=TREES)
    run_dir = _run_dir(tmp_path, shifted, odo=shifted, features=feats)
    out, s = _evaluate(bag, run_dir)
    assert 'no fit' in out and 'map (fitted)' in out and 'map (no fit)' in out
    assert s['fit'] == 'rigid_2d' and s['estimate']['path_rms'] == pytest.approx(0.0, abs=1e-6)
    nf = s['no_fit']['estimate']
    assert nf['path_rms'] > 0.5 and nf['final_error'] > nf['path_rms'] * 0.9
    assert s['map']['matched'] == 5 and s['no_fit']['map']['matched'] < 5
    # --no-fit: only that figure, the same as the default run's.
    _, s2 = _evaluate(bag, run_dir, '--no-fit')
    assert s2['fit'] == 'none' and 'no_fit' not in s2
    assert s2['estimate']['path_rms'] == pytest.approx(nf['path_rms'])
    assert s2['map']['matched'] == s['no_fit']['map']['matched']
    # Without reference headings the same holds (a GPS in the run's start frame).
    gps = _bag(tmp_path / 'gps.bag', points=(est[0][::10], est[1][::10]))
    _, s3 = _evaluate(gps, run_dir)
    assert s3['estimate']['path_rms'] < 1e-6 and s3['no_fit']['estimate']['path_rms'] > 0.5


def test_the_ate_aligned_at_the_first_pose_is_printed_below_the_fitted_one(tmp_path):
    est = _path()
    # The run's path turned by 0.1 rad about its start, its headings the reference's: the fit takes the turn
    # out, the alignment at the first pose (same heading there) does not: pose k is 2 sin(0.05) |p_k - p_0| off.
    p0 = est[1][0]
    turned = (est[0], (est[1] - p0) @ _rot(0.1).T + p0, est[2])
    expected = 2.0 * math.sin(0.05) * math.sqrt(np.mean(np.sum((est[1] - p0) ** 2, axis=1)))
    bag = _bag(tmp_path / 'odom.bag', odom=est)
    run_dir = _run_dir(tmp_path, turned, odo=est)
    out, s = _evaluate(bag, run_dir)
    assert s['estimate']['path_rms'] == pytest.approx(0.0, abs=1e-6)
    assert s['estimate']['path_rms_first_pose'] == pytest.approx(expected, rel=1e-6)
    assert s['odometry']['path_rms_first_pose'] == pytest.approx(0.0, abs=1e-9)
    line = [l for l in out.splitlines() if l.startswith('  at the first pose')]
    assert len(line) == 1 and line[0].split()[4:] == ['%.1f' % (1000 * expected), '0.0'], out
    assert out.splitlines().index(line[0]) == [l.startswith('ATE / path RMS') for l in out.splitlines()].index(True) + 1
    # The same with --no-fit; none where the reference has no headings (a GPS).
    os.remove(os.path.join(str(run_dir), 'evaluation.json'))
    _, s2 = _evaluate(bag, run_dir, '--no-fit')
    assert s2['estimate']['path_rms_first_pose'] == pytest.approx(expected, rel=1e-6)
    os.remove(os.path.join(str(run_dir), 'evaluation.json'))
    out, s3 = _evaluate(_bag(tmp_path / 'gps.bag', points=(est[0], est[1])), run_dir)
    assert s3['estimate']['path_rms_first_pose'] is None and 'at the first pose' not in out


def test_bad_references_are_one_line_and_write_nothing(tmp_path):
    est = _path()
    run_dir = _run_dir(tmp_path, est)
    left = ['estimate.tum']
    bag = _bag(tmp_path / 'fix.bag', fixes=[(100.0, 48.0, 11.0, -1), (101.0, float('nan'), 11.0, 0)])
    r = run('evaluate_bag_run', '--bag', bag, '--run', run_dir)
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, 'no valid fixes on /gps/fix', '2 skipped', left=left)
    r = run('evaluate_bag_run', '--bag', bag, '--run', run_dir, '--reference', '/ground_truth/odom')
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, 'no topic /ground_truth/odom in the bag (--reference)',
                         left=left)
    r = run('evaluate_bag_run', '--bag', bag, '--run', run_dir, '--truth-landmarks', '/gps/fix')
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, '/gps/fix is sensor_msgs/NavSatFix, not rbpf_slam/TrunkArray',
                         left=left)
    empty = _bag(tmp_path / 'empty.bag')
    r = run('evaluate_bag_run', '--bag', empty, '--run', run_dir)
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, 'no reference: no path topic', left=left)
    # Fixes all outside the run's time span.
    late = _bag(tmp_path / 'late.bag', points=(est[0] + 100.0, est[1]))
    r = run('evaluate_bag_run', '--bag', late, '--run', run_dir)
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, 'does not overlap the reference', '0 of %d' % len(est[0]),
                         left=left)
    # Landmarks but no map.csv, and no reference path: nothing to score.
    marks = _bag(tmp_path / 'marks.bag', landmarks=TREES)
    r = run('evaluate_bag_run', '--bag', marks, '--run', run_dir)
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, 'nothing to score', left=left)


def test_the_printed_table_of_a_summary():
    """rbpf_slam.evaluate_bag_run.table: the reference lines, the path figures in mm (a missing one as '-'), the map."""
    from rbpf_slam import evaluate_bag_run as ebr
    summary = {'notes': ['reference: /gps/fix'], 'fit': 'none', 'reference_poses': 10, 'reference_total': 12,
               'estimate': {'path_rms': 0.0123, 'final_error': 0.02, 'max_error': 0.03, 'rpe_translation': 0.004},
               'odometry': {'path_rms': 0.5},
               'map': {'features': 5, 'trees': 4, 'matched': 3, 'recall': 0.75, 'duplicates': 1, 'spurious': 1,
                       'mean_error': None},
               'health_warned_updates': [2, 40], 'seconds_processing': 0.25, 'sweeps': 7}
    assert ebr.table(summary).splitlines() == [
        'reference: /gps/fix',
        'compared: 10 of 12 reference poses inside the estimate\'s time span',
        '(no fit)                 estimate   odometry',
        'ATE / path RMS [mm]          12.3      500.0',
        'final error [mm]             20.0          -',
        'max error [mm]               30.0          -',
        'RPE trans. [mm]               4.0          -',
        'map: 5 features for 4 true landmarks: 3 matched (recall 75 %), 1 duplicates, 1 spurious',
        'health warned in 2 of 40 updates',
        'processing 250.0 ms (7 sweeps)']
    # The warnings per cause, where the run folder names them.
    summary['health_warned_by_cause'] = {'overconfident': 1, 'inconsistent': 1}
    assert 'health warned in 2 of 40 updates (inconsistent: 1, overconfident: 1)' in ebr.table(summary).splitlines()
