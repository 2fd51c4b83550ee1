"""Evaluation of an offline run against a bag's reference (the truth never enters the filter: the runner
reads only sensor topics; this module reads the truth topics afterwards). The package's one evaluator:
evaluate_bag_run (evaluate) and trajectory_eval (trajectory_errors) use it, plot_forest_run its RPE, and it
reads the package's one landmark CSV (read_landmarks_csv).

Metrics (REP-103 units: m, rad; printed in mm or deg where said):

* path RMS of the compared point (e.g. the scanner, ``point_offset`` on base_link) after a least-squares
  rigid 2D fit of the estimated path onto the reference (Horn / Umeyama without scale), or without a fit;
  the same for the run's raw odometry, anchored at the start like the estimate;
* final position error (with the same fit); as a diagnostic, the path RMS after a similarity fit (with
  scale) and that scale, which separate a scale error (of the sensors or of the reference) from the shape;
* RPE over pose pairs ``rpe_distance`` of reference travel apart (translation m, rotation deg; rotation
  only where the reference carries orientation);
* the map against the true landmarks, moved by the same fit, counted as ../shared/scenarios/README.md pins
  it (score_map): recall, duplicates, spurious, mean / RMS / max error of the matched, radius RMS.
"""
import csv
import math

import numpy as np

from rbpf_slam.geometry import se2_between, yaw_of


def read_tum(path):
    """(t, xy, yaw) of a TUM file (t x y z qx qy qz qw)."""
    try:
        data = np.loadtxt(path, ndmin=2)
    except ValueError as e:  # not numbers, or rows of different lengths
        raise ValueError('%s: not a TUM trajectory (%s)' % (path, ' '.join(str(e).split())))
    if data.size == 0:
        raise ValueError('%s: empty trajectory' % path)
    if data.shape[1] != 8:
        raise ValueError('%s: expected 8 columns (TUM: t x y z qx qy qz qw), got %d' % (path, data.shape[1]))
    return data[:, 0], data[:, 1:3], yaw_of(data[:, 4:8])


#: The columns of the package's one landmark CSV, in order (io::landmarksCsv writes it: slam_bag's map.csv,
#: the FastSLAM node's tree inventory, fastslam_benchmark's maps): metres, dbh = 2 x the trunk radius.
LANDMARK_COLUMNS = ('id', 'x', 'y', 'dbh', 'sigma_x', 'sigma_y', 'sigma_dbh', 'observations', 'provisional')


def read_landmarks_csv(path):
    """The landmark CSV (LANDMARK_COLUMNS) as a dict of numpy arrays, one per column ('id' and 'observations'
    integers, 'provisional' booleans), plus 'radius' = dbh / 2. Columns after these are ignored; a missing
    column or a malformed value is a ValueError naming the file (and the line)."""
    with open(path) as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            raise ValueError('%s: empty, expected the header %s' % (path, ','.join(LANDMARK_COLUMNS)))
        header = [h.strip() for h in header]
        missing = [c for c in LANDMARK_COLUMNS if c not in header]
        if missing:
            raise ValueError('%s: not a landmark CSV: no column %s (expected %s)'
                             % (path, ', '.join(missing), ','.join(LANDMARK_COLUMNS)))
        index = [header.index(c) for c in LANDMARK_COLUMNS]
        rows = []
        for row in reader:
            if not row:
                continue
            try:
                rows.append([float(row[i]) for i in index])
            except (IndexError, ValueError):
                raise ValueError('%s:%d: expected %d numbers (%s), got %r'
                                 % (path, reader.line_num, len(header), ','.join(header), ','.join(row)))
    data = np.array(rows, dtype=float).reshape(-1, len(LANDMARK_COLUMNS))
    out = {c: data[:, k] for k, c in enumerate(LANDMARK_COLUMNS)}
    for c in ('id', 'observations'):
        out[c] = out[c].astype(int)
    out['provisional'] = out['provisional'] != 0
    out['radius'] = out['dbh'] / 2.0
    return out


def read_map_csv(path, include_provisional=False):
    """Landmarks of a landmark CSV (a runner's map.csv) as an (n, 3) array x, y, radius; provisional ones
    only with ``include_provisional``."""
    m = read_landmarks_csv(path)
    keep = np.ones(len(m['x']), dtype=bool) if include_provisional else ~m['provisional']
    return np.column_stack([m['x'], m['y'], m['radius']])[keep].reshape(-1, 3)


def interpolate(t, xy, yaw, tq):
    """Poses at the times tq (linear in position, shortest way in heading); times outside are clamped."""
    x = np.interp(tq, t, xy[:, 0])
    y = np.interp(tq, t, xy[:, 1])
    uw = np.unwrap(yaw)
    return np.column_stack([x, y]), np.interp(tq, t, uw)


def point_of(xy, yaw, offset):
    """The point ``offset`` (x, y on the body) of each pose."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.column_stack([xy[:, 0] + c * offset[0] - s * offset[1], xy[:, 1] + s * offset[0] + c * offset[1]])


def fit_rigid_2d(src, dst):
    """Rotation R (2x2) and translation t minimising sum |R src + t - dst|^2."""
    src, dst = np.asarray(src, float), np.asarray(dst, float)
    if len(src) < 2:
        return np.eye(2), (dst.mean(axis=0) - src.mean(axis=0)) if len(src) else np.zeros(2)
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    h = (src - ms).T @ (dst - md)
    angle = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    r = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    return r, md - r @ ms


def aligned_rmse(src, dst):
    """ATE: the RMS [m] of the positions src (n, 2) after fit_rigid_2d onto their partners dst (n, 2)."""
    src, dst = np.asarray(src, float).reshape(-1, 2), np.asarray(dst, float).reshape(-1, 2)
    if not len(src):
        return float('nan')
    r, t = fit_rigid_2d(src, dst)
    return float(np.sqrt(np.mean(np.sum((src @ r.T + t - dst) ** 2, axis=1))))


def fit_similarity_2d(src, dst):
    """Scale s, rotation R and translation t minimising sum |s R src + t - dst|^2 (Umeyama)."""
    src, dst = np.asarray(src, float), np.asarray(dst, float)
    r, _ = fit_rigid_2d(src, dst)
    ms, md = src.mean(axis=0), dst.mean(axis=0)
    var = np.sum((src - ms) ** 2)
    scale = float(np.sum((dst - md) * ((src - ms) @ r.T)) / var) if var > 0 else 1.0
    return scale, r, md - scale * (r @ ms)


def relative_pose_errors(estimate, truth, delta=1.0):
    """The errors of each RPE pair (i, j), j the first pose >= delta metres of true travel after i: the SE(2)
    error of the estimate's relative motion against the truth's (Kuemmerle et al. 2009, "On measuring the
    accuracy of SLAM algorithms"). Rows (x, y, yaw), paired by index.

    Returns arrays (translation errors [m], rotation errors [deg]), one element per pair.
    """
    estimate, truth = np.asarray(estimate, float), np.asarray(truth, float)
    if len(estimate) != len(truth):
        raise ValueError('estimate and truth differ in length (%d, %d)' % (len(estimate), len(truth)))
    travel = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(truth[:, :2], axis=0).T))])
    trans, rot = [], []
    j = 0
    for i in range(len(truth)):
        j = max(j, i + 1)
        while j < len(truth) and travel[j] - travel[i] < delta - 1e-9:  # 1e-9: sums of decimal steps
            j += 1
        if j >= len(truth):
            break
        e = se2_between(se2_between(truth[i], truth[j]), se2_between(estimate[i], estimate[j]))
        trans.append(math.hypot(e[0], e[1]))
        rot.append(math.degrees(abs(e[2])))
    return np.array(trans, dtype=float), np.array(rot, dtype=float)


def relative_pose_error(estimate, truth, delta=1.0):
    """RPE RMS over the pairs of relative_pose_errors.

    Returns (translation RMS [m], rotation RMS [deg], number of pairs); (nan, nan, 0) without a pair.
    """
    trans, rot = relative_pose_errors(estimate, truth, delta)
    if not len(trans):
        return float('nan'), float('nan'), 0
    return float(np.sqrt(np.mean(np.square(trans)))), float(np.sqrt(np.mean(np.square(rot)))), len(trans)


def rpe(ref_xy, est_xy, distance, ref_yaw=None, est_yaw=None):
    """RPE with full poses where the reference has headings (relative_pose_error); with positions only, the
    error of the displacement's length over the same pairs. Returns (translation RMS [m], rotation RMS [deg]
    or None, pairs); (None, None, 0) without a pair."""
    if ref_yaw is not None and est_yaw is not None:
        t, r, n = relative_pose_error(np.column_stack([est_xy, est_yaw]), np.column_stack([ref_xy, ref_yaw]),
                                      distance)
        return (t, r, n) if n else (None, None, 0)
    travel = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(ref_xy, axis=0), axis=1))]
    errors = []
    for i in range(len(travel)):
        j = int(np.searchsorted(travel, travel[i] + distance - 1e-9))
        if j >= len(travel):
            break
        errors.append(abs(np.linalg.norm(ref_xy[j] - ref_xy[i]) - np.linalg.norm(est_xy[j] - est_xy[i])))
    if not errors:
        return None, None, 0
    return float(np.sqrt(np.mean(np.square(errors)))), None, len(errors)


def score_map(features, trees, gate=0.5, duplicate_radius=1.0):
    """Counts as ../shared/scenarios/README.md pins them: features (n, 3: x, y, r) matched to true trees
    (m, 3) one-to-one (optimal assignment) inside ``gate`` [m]; a duplicate is an unmatched feature within
    ``duplicate_radius`` of a matched tree that is not closer to another tree; every other unmatched
    feature is spurious (provisional features are passed in by the caller and count too)."""
    from scipy.optimize import linear_sum_assignment
    out = {'features': int(len(features)), 'trees': int(len(trees)), 'matched': 0, 'duplicates': 0, 'spurious': 0,
           'mean_error': None, 'rms_error': None, 'max_error': None, 'radius_rms': None, 'recall': 0.0}
    if len(trees) == 0:
        out['spurious'] = int(len(features))
        return out
    if len(features) == 0:
        return out
    d = np.linalg.norm(features[:, None, :2] - trees[None, :, :2], axis=2)
    cost = np.where(d <= gate, d, 1e6)
    rows, cols = linear_sum_assignment(cost)
    ok = cost[rows, cols] < 1e6
    rows, cols = rows[ok], cols[ok]
    errors = d[rows, cols]
    out['matched'] = int(len(rows))
    out['recall'] = float(len(rows)) / len(trees)
    if len(rows):
        out['mean_error'] = float(errors.mean())
        out['rms_error'] = float(np.sqrt(np.mean(errors ** 2)))
        out['max_error'] = float(errors.max())
        if np.all(trees[cols, 2] > 0):
            out['radius_rms'] = float(np.sqrt(np.mean((features[rows, 2] - trees[cols, 2]) ** 2)))
    matched_trees = set(int(c) for c in cols)
    for i in np.setdiff1d(np.arange(len(features)), rows):
        nearest = int(np.argmin(d[i]))
        if nearest in matched_trees and d[i, nearest] <= duplicate_radius:
            out['duplicates'] += 1
        else:
            out['spurious'] += 1
    return out


def read_bag_truth(bag_path, odom_topic, landmarks_topic=None):
    """(t, xy, yaw or None) of the reference and the true landmarks (m, 3) or None, from a bag."""
    import rosbag
    ts, xy, yaw, has_orientation, marks = [], [], [], False, None
    try:
        bag = rosbag.Bag(bag_path)
    except (rosbag.ROSBagException, ValueError) as e:  # ValueError: e.g. a binary file that is no bag
        raise ValueError('%s: not a readable bag (%s)' % (bag_path, e))
    with bag:
        for topic, msg, _ in bag.read_messages(topics=[t for t in (odom_topic, landmarks_topic) if t]):
            if topic == odom_topic:
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                ts.append(msg.header.stamp.to_sec())
                xy.append((p.x, p.y))
                yaw.append(math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z)))
                has_orientation = has_orientation or abs(q.z) > 1e-9 or abs(q.x) > 1e-9 or abs(q.y) > 1e-9
            elif topic == landmarks_topic and marks is None:
                marks = np.array([(tr.center.x, tr.center.y, tr.radius) for tr in msg.trunks], dtype=float).reshape(-1, 3)
    if not ts:
        raise ValueError('%s: no nav_msgs/Odometry on %s (the reference)' % (bag_path, odom_topic))
    return np.array(ts), np.array(xy), (np.array(yaw) if has_orientation else None), marks


def match_by_stamp(t, ref_t, tolerance):
    """Pairs of a trajectory's poses with the reference's by stamp (both sorted): for each stamp of ``t`` the
    reference stamp nearest to it (the later one on a tie), kept where they are at most ``tolerance`` [s]
    apart. Returns index arrays (into t, into ref_t) of the pairs."""
    t, ref_t = np.asarray(t, float), np.asarray(ref_t, float)
    if not len(t) or not len(ref_t):
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    right = np.clip(np.searchsorted(ref_t, t, side='right'), 0, len(ref_t) - 1)
    left = np.clip(right - 1, 0, len(ref_t) - 1)
    nearest = np.where(np.abs(ref_t[right] - t) <= np.abs(ref_t[left] - t), right, left)
    keep = np.abs(ref_t[nearest] - t) <= tolerance
    return np.flatnonzero(keep), nearest[keep]


def trajectory_errors(run, ref, travel=1.0, tolerance=1e-3):
    """The trajectory metrics of ``trajectory_eval``: ``run`` and ``ref`` are (t, xy, yaw) as read_tum returns
    them (ref's yaw None: a reference of positions only), paired by match_by_stamp. Returns a dict: ``poses``
    paired; ``ate``, the ATE RMS [m] after a rigid SE(2) fit (aligned_rmse); over the RPE pairs ``travel``
    metres of reference travel apart (relative_pose_errors), ``rpe_pairs``, ``rpe_translation_mean`` /
    ``_rms`` [m] and ``rpe_rotation_mean_deg`` / ``_rms_deg`` (None without reference headings). Values
    without a pair are nan."""
    i, j = match_by_stamp(run[0], ref[0], tolerance)
    ref_yaw = ref[2] if ref[2] is not None else np.zeros(len(ref[0]))
    trans, rot = relative_pose_errors(np.column_stack([run[1][i], run[2][i]]),
                                      np.column_stack([ref[1][j], ref_yaw[j]]), travel)
    nan = float('nan')

    def mean(v):
        return float(np.mean(v)) if len(v) else nan

    def rms(v):
        return float(np.sqrt(np.mean(np.square(v)))) if len(v) else nan
    headings = ref[2] is not None
    return {'poses': int(len(i)), 'ate': aligned_rmse(run[1][i], ref[1][j]), 'rpe_pairs': int(len(trans)),
            'rpe_translation_mean': mean(trans), 'rpe_translation_rms': rms(trans),
            'rpe_rotation_mean_deg': mean(rot) if headings else None,
            'rpe_rotation_rms_deg': rms(rot) if headings else None}


def tum_text(t, xy, yaw):
    """A planar trajectory as TUM lines (t x y z qx qy qz qw; z = 0, rotation about z), as io::writeTum."""
    return ''.join('%.12g %.12g %.12g 0 0 0 %.12g %.12g\n' % (ti, p[0], p[1], math.sin(0.5 * a), math.cos(0.5 * a))
                   for ti, p, a in zip(t, xy, yaw))


def evaluate(est, odom, ref_t, ref_xy, ref_yaw=None, truth_map=None, features=None, point_offset=(0.0, 0.0),
             fit=True, gate=0.5, rpe_distance=1.0):
    """Every metric of one run. est / odom: (t, xy, yaw) as read_tum returns them."""
    sel = (ref_t >= est[0][0]) & (ref_t <= est[0][-1])
    if sel.sum() < 2:
        raise ValueError('the estimate (%.3f .. %.3f s) does not overlap the reference (%.3f .. %.3f s)'
                         % (est[0][0], est[0][-1], ref_t[0], ref_t[-1]))
    rt, rxy = ref_t[sel], ref_xy[sel]
    ryaw = ref_yaw[sel] if ref_yaw is not None else None
    summary = {'reference_poses': int(sel.sum()), 'fit': 'rigid_2d' if fit else 'none',
               'point_offset': list(point_offset)}
    transforms = {}
    for name, run in (('estimate', est), ('odometry', odom)):
        if run is None:
            continue
        xy, yaw = interpolate(run[0], run[1], run[2], rt)
        pts = point_of(xy, yaw, point_offset)
        r, t = fit_rigid_2d(pts, rxy) if fit else (np.eye(2), np.zeros(2))
        moved = pts @ r.T + t
        err = np.linalg.norm(moved - rxy, axis=1)
        fitted_yaw = yaw + math.atan2(r[1, 0], r[0, 0])
        t_rpe, r_rpe, pairs = rpe(rxy, moved, rpe_distance, ryaw, fitted_yaw if ryaw is not None else None)
        # Diagnostic: the shape alone (a similarity fit also removes a scale error of the run or the reference).
        sc, sr, st = fit_similarity_2d(pts, rxy)
        err_scaled = np.linalg.norm(sc * pts @ sr.T + st - rxy, axis=1)
        summary[name] = {'path_rms': float(np.sqrt(np.mean(err ** 2))), 'final_error': float(err[-1]),
                         'path_rms_similarity': float(np.sqrt(np.mean(err_scaled ** 2))), 'similarity_scale': sc,
                         'max_error': float(err.max()), 'rpe_translation': t_rpe, 'rpe_rotation_deg': r_rpe,
                         'rpe_pairs': pairs}
        transforms[name] = (r, t, moved, err)
    if truth_map is not None and features is not None:
        r, t = transforms['estimate'][:2]
        moved = features.copy()
        if len(moved):
            moved[:, :2] = features[:, :2] @ r.T + t
        summary['map'] = score_map(moved, truth_map, gate)
        transforms['map'] = moved
    return summary, transforms, (rt, rxy)
