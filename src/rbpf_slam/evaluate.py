"""Evaluation of an offline run against a bag's reference (the truth never enters the filter: the runner
reads only sensor topics; this module reads the truth topics afterwards). The package's one evaluator:
evaluate_bag_run (evaluate) and trajectory_eval (trajectory_errors) use it, plot_forest_run its RPE, and it
reads the package's one landmark CSV (read_landmarks_csv) and trajectory files (read_tum; read_trajectory:
TUM or ``t x y theta``).

Metrics (REP-103 units: m, rad; printed in mm or deg where said):

* path RMS of the compared point (e.g. the scanner, ``point_offset`` on base_link) after a least-squares
  rigid 2D fit of the estimated path onto the reference (Horn / Umeyama without scale), or without a fit;
  the same for the run's raw odometry, anchored at the start like the estimate; where the reference has
  headings, also the path RMS aligned at the first pose (first_pose_rmse: the run's first compared pose put on
  the reference's, position and heading, no fit);
* final position error (with the same fit); as a diagnostic, the path RMS after a similarity fit (with
  scale) and that scale, which separate a scale error (of the sensors or of the reference) from the shape;
* RPE over pose pairs ``rpe_distance`` of reference travel apart (translation m, rotation deg; rotation
  only where the reference carries orientation);
* the map against the true landmarks, moved by the same fit, counted one-to-one within a gate (score_map):
  recall, duplicates, spurious, mean / RMS / max error of the matched, radius RMS; without a
  reference path, after a rigid fit of the map itself onto the true landmarks (fit_map_rigid).

trajectory_eval pairs a trajectory's poses with the reference's by stamp (match_by_stamp: nearest,
order-preserving, equal stamps in file order) or by index (match_by_index) instead of interpolating.

The reference (read_bag_reference) is a path of poses (nav_msgs/Odometry, PoseStamped), or of positions only:
a GPS as geometry_msgs/PointStamped in a local metric frame, or sensor_msgs/NavSatFix converted to a local
east-north tangent plane on WGS84 about the first valid fix (geodetic_to_enu); the true landmarks are an
rbpf_slam/TrunkArray (/ground_truth/landmarks of the converters, /ground_truth/trees of the simulator).
"""
import csv
import math
import os
import struct

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


#: The layouts read_trajectory accepts, by column count.
TRAJECTORY_LAYOUTS = {8: 'TUM: t x y z qx qy qz qw', 4: 't x y theta'}


def _layouts():
    return ' or '.join('%d (%s)' % (n, what) for n, what in sorted(TRAJECTORY_LAYOUTS.items(), reverse=True))


def read_trajectory(path):
    """(t, xy, yaw) of a trajectory file of one pose a line, in either layout, told apart per file by its
    first pose line: TUM (8 columns: t x y z qx qy qz qw, the package's estimate.tum / odometry.tum) or
    ``t x y theta`` (4 columns, theta in rad, as other SLAM systems write per scan). Blank lines and lines
    starting with '#' are skipped; poses are kept in file order. Anything else is a ValueError
    ``file:line: expected ...``."""
    rows, width = [], None
    try:
        with open(path) as f:
            for number, line in enumerate(f, 1):
                fields = line.split()
                if not fields or fields[0].startswith('#'):
                    continue
                if width is None:
                    if len(fields) not in TRAJECTORY_LAYOUTS:
                        raise ValueError('%s:%d: expected %s columns, got %d'
                                         % (path, number, _layouts(), len(fields)))
                    width = len(fields)
                elif len(fields) != width:
                    raise ValueError('%s:%d: expected %d columns (%s) as on the first pose line, got %d'
                                     % (path, number, width, TRAJECTORY_LAYOUTS[width], len(fields)))
                try:
                    values = [float(v) for v in fields]
                except ValueError:
                    values = None
                if values is None or not all(math.isfinite(v) for v in values):
                    raise ValueError('%s:%d: expected %d finite numbers (%s), got %r'
                                     % (path, number, width, TRAJECTORY_LAYOUTS[width], line.strip()[:80]))
                rows.append(values)
    except UnicodeDecodeError:
        raise ValueError('%s: not a text file, expected lines of %s columns' % (path, _layouts()))
    if not rows:
        raise ValueError('%s: empty trajectory, expected lines of %s columns' % (path, _layouts()))
    data = np.array(rows, dtype=float)
    if width == 8:
        return data[:, 0], data[:, 1:3], yaw_of(data[:, 4:8])
    return data[:, 0], data[:, 1:3], data[:, 3]


#: The columns of the package's one landmark CSV, in order (io::landmarksCsv writes it: slam_bag's map.csv,
#: the FastSLAM node's tree inventory and saved maps, fastslam_benchmark's maps): metres, dbh = 2 x the trunk radius.
LANDMARK_COLUMNS = ('id', 'x', 'y', 'dbh', 'sigma_x', 'sigma_y', 'sigma_dbh', 'observations', 'provisional')
#: Columns after them in a tree map file: the centre's covariance [m^2] and the first and last sighting [s]
#: (empty when not known).
LANDMARK_OPTIONAL_COLUMNS = ('cov_xy', 'first_seen', 'last_seen')


def read_landmarks_csv(path):
    """The landmark CSV (LANDMARK_COLUMNS) as a dict of numpy arrays, one per column ('id' and 'observations'
    integers, 'provisional' booleans), plus 'radius' = dbh / 2, the LANDMARK_OPTIONAL_COLUMNS (cov_xy 0, times
    NaN where absent or empty) and 'anchor' (a dict of the '# anchor:' line's values, or None). Comment lines
    ('#') are skipped; other columns are ignored; a missing column or a malformed value is a ValueError naming
    the file (and the line)."""
    anchor = None
    lines = []
    with open(path) as f:
        for number, text in enumerate(f, 1):
            if text.lstrip().startswith('#'):
                body = text.lstrip()[1:].strip()
                if body.startswith('anchor:'):
                    try:
                        anchor = {k: float(v) for k, v in (item.split('=', 1) for item in body[7:].split())}
                    except ValueError:
                        raise ValueError('%s:%d: expected key=number pairs in the anchor, got %r'
                                         % (path, number, body))
                continue
            lines.append((number, text))
    reader = csv.reader(text for _, text in lines)
    header = next(reader, None)
    if header is None:
        raise ValueError('%s: empty, expected the header %s' % (path, ','.join(LANDMARK_COLUMNS)))
    header = [h.strip() for h in header]
    missing = [c for c in LANDMARK_COLUMNS if c not in header]
    if missing:
        raise ValueError('%s: not a landmark CSV: no column %s (expected %s)'
                         % (path, ', '.join(missing), ','.join(LANDMARK_COLUMNS)))
    index = [header.index(c) for c in LANDMARK_COLUMNS]
    optional = [(c, header.index(c)) for c in LANDMARK_OPTIONAL_COLUMNS if c in header]
    rows, extra = [], []
    for k, row in enumerate(reader, 1):
        if not row:
            continue
        number = lines[k][0] if k < len(lines) else k + 1
        try:
            rows.append([float(row[i]) for i in index])
            extra.append([float(row[i]) if row[i].strip() else float('nan') for _, i in optional])
        except (IndexError, ValueError):
            raise ValueError('%s:%d: expected %d numbers (%s), got %r'
                             % (path, number, len(header), ','.join(header), ','.join(row)))
    data = np.array(rows, dtype=float).reshape(-1, len(LANDMARK_COLUMNS))
    out = {c: data[:, k] for k, c in enumerate(LANDMARK_COLUMNS)}
    for c in ('id', 'observations'):
        out[c] = out[c].astype(int)
    out['provisional'] = out['provisional'] != 0
    out['radius'] = out['dbh'] / 2.0
    more = np.array(extra, dtype=float).reshape(len(rows), len(optional))
    for c in LANDMARK_OPTIONAL_COLUMNS:
        out[c] = np.zeros(len(rows)) if c == 'cov_xy' else np.full(len(rows), np.nan)
    for k, (c, _) in enumerate(optional):
        out[c] = more[:, k]
    out['anchor'] = anchor
    return out


def read_map_csv(path, include_provisional=False, with_ids=False):
    """Landmarks of a landmark CSV (a runner's map.csv) as an (n, 3) array x, y, radius; provisional ones
    only with ``include_provisional``; with ``with_ids`` (array, their ids)."""
    m = read_landmarks_csv(path)
    keep = np.ones(len(m['x']), dtype=bool) if include_provisional else ~m['provisional']
    xyr = np.column_stack([m['x'], m['y'], m['radius']])[keep].reshape(-1, 3)
    return (xyr, np.asarray(m['id'])[keep]) if with_ids else xyr


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


def first_pose_fit(xy0, yaw0, ref_xy0, ref_yaw0):
    """Rotation R (2x2) and translation t of the rigid motion that puts the pose (xy0, yaw0) on the pose
    (ref_xy0, ref_yaw0), position and heading: R xy0 + t = ref_xy0, R turning by ref_yaw0 - yaw0."""
    a = float(ref_yaw0) - float(yaw0)
    r = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return r, np.asarray(ref_xy0, float) - r @ np.asarray(xy0, float)


def first_pose_rmse(xy, yaw, ref_xy, ref_yaw):
    """ATE aligned at the first pose: the RMS [m] of the positions xy (n, 2) against their partners ref_xy
    (n, 2) after the run is moved so that its first pose (xy[0], yaw[0]) lies on the reference's first
    (ref_xy[0], ref_yaw[0]), position and heading (first_pose_fit; no fit over the path). nan without poses."""
    xy, ref_xy = np.asarray(xy, float).reshape(-1, 2), np.asarray(ref_xy, float).reshape(-1, 2)
    if not len(xy):
        return float('nan')
    r, t = first_pose_fit(xy[0], yaw[0], ref_xy[0], ref_yaw[0])
    return float(np.sqrt(np.mean(np.sum((xy @ r.T + t - ref_xy) ** 2, axis=1))))


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
    """Counts the map: features (n, 3: x, y, r) matched to true trees (m, 3) one-to-one (optimal assignment)
    inside ``gate`` [m]; recall = matched / m, reported beside the duplicates and the spurious features (the
    caller passes only the trees that count, e.g. those seen within the sensor's scope); a duplicate is an
    unmatched feature within ``duplicate_radius`` of a matched tree that is not closer to another tree; every
    other unmatched feature is spurious (provisional features are passed in by the caller and count too)."""
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


def read_bag_truth(bag_path, odom_topic, landmarks_topic=None, what='the reference'):
    """(t, xy, yaw or None) of the nav_msgs/Odometry on ``odom_topic`` (the reference; ``what`` names it in
    the error where the topic has none) and the true landmarks (m, 3) or None, from a bag."""
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
        raise ValueError('%s: no nav_msgs/Odometry on %s (%s)' % (bag_path, odom_topic, what))
    return np.array(ts), np.array(xy), (np.array(yaw) if has_orientation else None), marks


#: Message types a reference path can come in: full poses, or positions only (a GPS in a local metric frame,
#: or a GPS fix in latitude / longitude, converted to a local ENU frame about the first valid fix).
REFERENCE_TYPES = ('nav_msgs/Odometry', 'geometry_msgs/PoseStamped', 'geometry_msgs/PoseWithCovarianceStamped',
                   'geometry_msgs/PointStamped', 'sensor_msgs/NavSatFix')
#: The reference path topics looked for, in this order, when none is named (then any NavSatFix topic).
DEFAULT_REFERENCE_TOPICS = ('/ground_truth/odom', '/gps/fix', '/gps', '/fix')
#: The true landmark topics (rbpf_slam/TrunkArray) looked for, in this order, when none is named: the data
#: set converters write /ground_truth/landmarks, the simulator and record_scenario /ground_truth/trees.
DEFAULT_LANDMARK_TOPICS = ('/ground_truth/landmarks', '/ground_truth/trees')
LANDMARK_TYPE = 'rbpf_slam/TrunkArray'

#: WGS84 ellipsoid: semi-major axis [m] and flattening.
WGS84_A = 6378137.0
WGS84_F = 1.0 / 298.257223563


def geodetic_to_ecef(lat_deg, lon_deg, height=0.0):
    """Earth-centred, earth-fixed coordinates [m] of WGS84 latitude / longitude [deg] and ellipsoidal height [m]."""
    lat, lon = np.radians(np.asarray(lat_deg, float)), np.radians(np.asarray(lon_deg, float))
    e2 = WGS84_F * (2.0 - WGS84_F)
    n = WGS84_A / np.sqrt(1.0 - e2 * np.sin(lat) ** 2)  # prime vertical radius of curvature
    return np.stack([(n + height) * np.cos(lat) * np.cos(lon), (n + height) * np.cos(lat) * np.sin(lon),
                     (n * (1.0 - e2) + height) * np.sin(lat)], axis=-1)


def geodetic_to_enu(lat_deg, lon_deg, lat0_deg, lon0_deg):
    """East and north [m] (an (n, 2) array) of WGS84 latitudes / longitudes [deg] in the local tangent plane
    at (lat0, lon0) on the ellipsoid: exact through ECEF, heights ignored (all points on the ellipsoid), so
    that a 2D path is compared in the plane the robot drives in."""
    d = geodetic_to_ecef(lat_deg, lon_deg) - geodetic_to_ecef(lat0_deg, lon0_deg)
    lat0, lon0 = math.radians(lat0_deg), math.radians(lon0_deg)
    east = -math.sin(lon0) * d[..., 0] + math.cos(lon0) * d[..., 1]
    north = (-math.sin(lat0) * math.cos(lon0) * d[..., 0] - math.sin(lat0) * math.sin(lon0) * d[..., 1]
             + math.cos(lat0) * d[..., 2])
    return np.column_stack([np.ravel(east), np.ravel(north)])


def _stamp(msg, bag_time):
    s = msg.header.stamp.to_sec()
    return s if s > 0 else bag_time.to_sec()  # an unstamped message: its bag time


def _yaw_of_quaternion(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def _slash(topic):
    return topic if topic.startswith('/') else '/' + topic


def _pick(requested, defaults, types, wanted, option):
    """The topic to read: ``requested`` (None: the first of ``defaults`` present with a type in ``wanted``;
    'none': no topic), checked against the bag's ``types`` {topic: type}."""
    if requested is not None:
        if requested.lower() == 'none':
            return None
        topic = requested if requested in types else _slash(requested)
        if topic not in types:
            raise ValueError('no topic %s in the bag (%s)' % (requested, option))
        if types[topic] not in wanted:
            raise ValueError('%s is %s, not %s (%s)' % (topic, types[topic], ' or '.join(wanted), option))
        return topic
    for topic in defaults:
        if types.get(topic) in wanted:
            return topic
    return None


def _read_reference_messages(bag, path_topic, kind, marks_topic, rows, frames, out):
    """read_bag_reference's loop: (t, x, y, yaw) of each valid path message into rows (its frame into
    frames), the first TrunkArray into out['landmarks'], the counts into out."""
    for topic, msg, bag_time in bag.read_messages(topics=[t for t in (path_topic, marks_topic) if t]):
        if topic == marks_topic:
            if out['landmarks'] is None:
                out['landmarks'] = np.array([(tr.center.x, tr.center.y, tr.radius) for tr in msg.trunks],
                                            dtype=float).reshape(-1, 3)
                out['landmark_ids'] = np.array([tr.id for tr in msg.trunks], dtype=int)
                out['landmarks_frame'] = msg.header.frame_id
            continue
        out['messages'] += 1
        yaw = float('nan')
        if kind == 'sensor_msgs/NavSatFix':
            ok = msg.status.status >= 0 and abs(msg.latitude) <= 90.0 and abs(msg.longitude) <= 180.0
            x, y = msg.latitude, msg.longitude  # converted below, about the first valid fix
        elif kind == 'geometry_msgs/PointStamped':
            ok, x, y = True, msg.point.x, msg.point.y
        else:
            pose = msg.pose.pose if kind != 'geometry_msgs/PoseStamped' else msg.pose
            ok, x, y = True, pose.position.x, pose.position.y
            q = pose.orientation
            yaw = _yaw_of_quaternion(q) if abs(q.x) + abs(q.y) + abs(q.z) > 1e-9 else float('nan')
        t = _stamp(msg, bag_time)
        if not (ok and math.isfinite(x) and math.isfinite(y) and math.isfinite(t)):
            out['skipped'] += 1
            continue
        rows.append((t, x, y, yaw))
        frames.append(msg.header.frame_id)


def read_bag_reference(bag_path, reference_topic=None, landmarks_topic=None):
    """The reference path and the true landmarks of a bag, as a dict:

    * ``topic``, ``type``, ``frame``: the reference path (None for all when the bag has none);
      ``reference_topic`` None picks the first of DEFAULT_REFERENCE_TOPICS in the bag, else its only
      NavSatFix topic; 'none' reads no path. Any of REFERENCE_TYPES;
    * ``t``, ``xy`` (n, 2) [m] sorted by stamp, ``yaw`` (or None for a reference of positions only),
      ``messages`` (all of the topic) and ``skipped`` (NavSatFix without a fix, status < 0, or values that
      are not finite); ``origin`` (lat, lon) [deg] of the ENU frame of a NavSatFix reference (its first valid
      fix), else None;
    * ``landmarks`` (m, 3: x, y, radius) of the first rbpf_slam/TrunkArray on ``landmarks_topic`` (None: the
      first of DEFAULT_LANDMARK_TOPICS in the bag; 'none': none), ``landmarks_topic``, ``landmarks_frame``;
      None where the bag has none;
    * ``notes``: lines that say what was read and what is missing.

    A bag with neither, a named topic that is missing or of another type, or a path topic without one valid
    message is a ValueError naming the bag.
    """
    import genpy
    import rosbag
    try:
        bag = rosbag.Bag(bag_path)
    except (rosbag.ROSBagException, ValueError) as e:  # ValueError: e.g. a binary file that is no bag
        raise ValueError('%s: not a readable bag (%s)' % (bag_path, e))
    out = {'topic': None, 'type': None, 'frame': None, 't': None, 'xy': None, 'yaw': None, 'messages': 0,
           'skipped': 0, 'origin': None, 'landmarks': None, 'landmark_ids': None, 'landmarks_topic': None,
           'landmarks_frame': None, 'notes': []}
    with bag:
        types = {topic: info.msg_type for topic, info in bag.get_type_and_topic_info().topics.items()}
        try:
            path_topic = _pick(reference_topic, DEFAULT_REFERENCE_TOPICS, types, REFERENCE_TYPES, '--reference')
            if path_topic is None and reference_topic is None:
                fixes = sorted(t for t, ty in types.items() if ty == 'sensor_msgs/NavSatFix')
                path_topic = fixes[0] if len(fixes) == 1 else None
            marks_topic = _pick(landmarks_topic, DEFAULT_LANDMARK_TOPICS, types, (LANDMARK_TYPE,),
                                '--truth-landmarks')
        except ValueError as e:
            raise ValueError('%s: %s' % (bag_path, e))
        paths = ('--reference none' if reference_topic is not None
                 else 'none of %s, nor one NavSatFix topic' % ', '.join(DEFAULT_REFERENCE_TOPICS))
        marks = ('--truth-landmarks none' if landmarks_topic is not None
                 else 'no %s on %s' % (LANDMARK_TYPE, ' or '.join(DEFAULT_LANDMARK_TOPICS)))
        if path_topic is None and marks_topic is None:
            raise ValueError('%s: no reference: no path topic (%s) and no true landmarks (%s)'
                             % (bag_path, paths, marks))
        kind = types.get(path_topic)
        rows, frames = [], []
        try:
            _read_reference_messages(bag, path_topic, kind, marks_topic, rows, frames, out)
        except (rosbag.ROSBagException, genpy.DeserializationError, struct.error) as e:  # a truncated or damaged bag
            raise ValueError('%s: cannot read %s (%s)' % (bag_path, ' and '.join(t for t in (path_topic, marks_topic)
                                                                                  if t), ' '.join(str(e).split())))
    if path_topic is not None:
        what = 'fixes' if kind in ('sensor_msgs/NavSatFix', 'geometry_msgs/PointStamped') else 'poses'
        if not rows:
            raise ValueError('%s: no valid %s on %s (%s, %d message(s), %d skipped: %s)'
                             % (bag_path, what, path_topic, kind, out['messages'], out['skipped'],
                                'no fix or not finite' if kind == 'sensor_msgs/NavSatFix' else 'not finite'))
        data = np.array(rows, dtype=float)
        order = np.argsort(data[:, 0], kind='stable')
        data = data[order]
        out.update(topic=path_topic, type=kind, frame=frames[int(order[0])], t=data[:, 0])
        if kind == 'sensor_msgs/NavSatFix':
            first = rows[0]  # the first valid fix in the bag's order
            out['origin'] = (first[1], first[2])
            out['xy'] = geodetic_to_enu(data[:, 1], data[:, 2], first[1], first[2])
            out['frame'] = 'ENU about the first valid fix (%.7f, %.7f)' % out['origin']
        else:
            out['xy'] = data[:, 1:3]
        yaws = data[:, 3]
        # Poses whose orientation is all zero (a position-only reference in a pose message) have no heading.
        out['yaw'] = np.nan_to_num(yaws, nan=0.0) if np.any(np.isfinite(yaws)) else None
        line = 'reference: %s (%s%s), %d %s' % (path_topic, kind, ', found in the bag; --reference to choose'
                                                if reference_topic is None else '', len(rows), what)
        if kind == 'sensor_msgs/NavSatFix':
            line += ' in ENU about the first valid fix (lat %.7f, lon %.7f)' % out['origin']
        if out['skipped'] or kind == 'sensor_msgs/NavSatFix':
            line += '; %d of %d skipped (%s)' % (out['skipped'], out['messages'], 'no fix or not finite'
                                                   if kind == 'sensor_msgs/NavSatFix' else 'not finite')
        out['notes'].append(line)
    else:
        out['notes'].append('reference: no path (%s): the map is scored alone' % paths)
    if marks_topic is None:
        out['notes'].append('true landmarks: none (%s): the map is not scored' % marks)
    elif out['landmarks'] is None:
        out['notes'].append('true landmarks: %s has no message: the map is not scored' % marks_topic)
    else:
        out['landmarks_topic'] = marks_topic
        out['notes'].append('true landmarks: %s, %d in frame %s' % (marks_topic, len(out['landmarks']),
                                                                    out['landmarks_frame'] or '(none)'))
        if out['frame'] and out['landmarks_frame'] and out['frame'].lstrip('/') != out['landmarks_frame'].lstrip('/'):
            out['notes'].append('true landmarks: frame %s differs from the reference path\'s (%s): compared as one '
                                'frame' % (out['landmarks_frame'], out['frame']))
    return out


def match_by_stamp(t, ref_t, tolerance):
    """Pairs of a trajectory's poses with the reference's by stamp, order-preserving. The reference's stamps
    must not go backwards (a ValueError); the trajectory's are taken in file order. For each pose:

    * its candidate stamp is the reference stamp nearest to its own (the later one on a tie);
    * where several reference poses share that stamp, the pose's rank among the trajectory's poses with
      exactly its own stamp picks among them: the k-th pose stamped t is paired with the k-th reference
      pose stamped t, in file order; a k-th pose without a k-th reference pose stays unpaired;
    * the pairing is monotone: a pose is never paired with a reference pose before the previous paired
      pose's partner (where it would be, it takes that partner too: e.g. a pose stamped just after a run
      of equal stamps that all found partners);
    * it is kept where its partner's stamp is at most ``tolerance`` [s] from its own.

    Returns index arrays (into t, into ref_t) of the pairs; the second never decreases, and repeats where
    several poses share one partner (stamps coarser than the poses: shared_partners counts them)."""
    t, ref_t = np.asarray(t, float).ravel(), np.asarray(ref_t, float).ravel()
    if not len(t) or not len(ref_t):
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    back = np.flatnonzero(np.diff(ref_t) < 0)
    if len(back):
        k = int(back[0]) + 1
        raise ValueError('the reference\'s stamps go backwards at pose %d (%.6f s after %.6f s): pairing by '
                         'stamp needs them in order' % (k + 1, ref_t[k], ref_t[k - 1]))
    values, first, counts = np.unique(ref_t, return_index=True, return_counts=True)
    later = np.clip(np.searchsorted(values, t, side='left'), 0, len(values) - 1)
    earlier = np.clip(later - 1, 0, len(values) - 1)
    group = np.where(np.abs(values[later] - t) <= np.abs(values[earlier] - t), later, earlier)
    seen, pairs, last = {}, [], 0
    for i, (stamp, g) in enumerate(zip(t.tolist(), group.tolist())):
        rank = seen.get(stamp, 0)
        seen[stamp] = rank + 1
        if rank >= counts[g]:
            continue  # more poses with this stamp than reference poses with the nearest one
        j = max(int(first[g]) + rank, last)
        if abs(ref_t[j] - stamp) <= tolerance:
            pairs.append((i, j))
            last = j
    if not pairs:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    i, j = np.array(pairs, dtype=int).T
    return i, j


def shared_partners(j):
    """How many pairs of a stamp pairing (the reference indices ``j``) have a reference pose that an earlier
    pair already has: poses paired with another pose's partner, e.g. when coarse stamps put two poses on one
    reference stamp. 0 for a one-to-one pairing."""
    j = np.asarray(j, int)
    return int(len(j) - len(np.unique(j)))


def match_by_index(n, n_ref):
    """Pairs by order: the k-th pose with the k-th reference pose; the counts must be equal (a ValueError
    naming both). Returns index arrays (into the trajectory, into the reference)."""
    if n != n_ref:
        raise ValueError('%d poses against %d reference poses: pairing by index needs as many' % (n, n_ref))
    return np.arange(n), np.arange(n)


#: How trajectory_errors pairs a trajectory's poses with the reference's.
PAIRINGS = ('stamp', 'index')


def trajectory_errors(run, ref, travel=1.0, tolerance=1e-3, pair='stamp'):
    """The trajectory metrics of ``trajectory_eval``: ``run`` and ``ref`` are (t, xy, yaw) as read_trajectory
    returns them (ref's yaw None: a reference of positions only), paired by match_by_stamp (``pair`` 'stamp',
    within ``tolerance`` [s]) or match_by_index ('index'). Returns a dict: ``poses`` paired; ``ate``, the ATE
    RMS [m] after a rigid SE(2) fit (aligned_rmse); ``ate_first_pose``, the ATE RMS [m] with the run's first
    paired pose put on the reference's (first_pose_rmse; None without reference headings); over the RPE pairs
    ``travel`` metres of reference travel apart (relative_pose_errors), ``rpe_pairs``,
    ``rpe_translation_mean`` / ``_rms`` [m] and ``rpe_rotation_mean_deg`` / ``_rms_deg`` (None without
    reference headings); ``shared_partners``, the pairs whose reference pose another pair has too
    (shared_partners; coarse stamps). Values without a pair are nan."""
    if pair == 'stamp':
        i, j = match_by_stamp(run[0], ref[0], tolerance)
    elif pair == 'index':
        i, j = match_by_index(len(run[0]), len(ref[0]))
    else:
        raise ValueError('pairing %r: expected one of %s' % (pair, ', '.join(PAIRINGS)))
    headings = ref[2] is not None
    ref_yaw = np.asarray(ref[2], float) if headings else np.zeros(len(ref[0]))
    run_xy, run_yaw = np.asarray(run[1], float)[i], np.asarray(run[2], float)[i]
    ref_xy = np.asarray(ref[1], float)[j]
    trans, rot = relative_pose_errors(np.column_stack([run_xy, run_yaw]), np.column_stack([ref_xy, ref_yaw[j]]),
                                      travel)
    nan = float('nan')

    def mean(v):
        return float(np.mean(v)) if len(v) else nan

    def rms(v):
        return float(np.sqrt(np.mean(np.square(v)))) if len(v) else nan
    return {'poses': int(len(i)), 'shared_partners': shared_partners(j), 'ate': aligned_rmse(run_xy, ref_xy),
            'ate_first_pose': first_pose_rmse(run_xy, run_yaw, ref_xy, ref_yaw[j]) if headings else None,
            'rpe_pairs': int(len(trans)), 'rpe_translation_mean': mean(trans), 'rpe_translation_rms': rms(trans),
            'rpe_rotation_mean_deg': mean(rot) if headings else None,
            'rpe_rotation_rms_deg': rms(rot) if headings else None}


def format_stamp(t):
    """A time stamp [s] as text for a TUM or CSV file, to the nanosecond: 12 significant digits of a Unix stamp
    (1.7e9 s) are 10 ms; a double holds about 0.2 us there."""
    return '%.9f' % t


def tum_text(t, xy, yaw):
    """A planar trajectory as TUM lines (t x y z qx qy qz qw; z = 0, rotation about z), as io::writeTum; the
    stamps to the nanosecond (format_stamp)."""
    return ''.join('%s %.12g %.12g 0 0 0 %.12g %.12g\n' % (format_stamp(ti), p[0], p[1], math.sin(0.5 * a),
                                                           math.cos(0.5 * a))
                   for ti, p, a in zip(t, xy, yaw))


#: A fit of a map onto the true landmarks over fewer matches than this is no score: two points fit any two points.
MIN_MAP_FIT_MATCHES = 3


def _refine_map_fit(features, trees, r, t, gate, iterations=20):
    """From (r, t): match one-to-one (optimal assignment) inside ``gate``, fit over the matches, again until the
    matches stay the same. Returns (R, t, matches)."""
    from scipy.optimize import linear_sum_assignment
    previous, used = None, 0
    for _ in range(iterations):
        moved = features[:, :2] @ r.T + t
        d = np.linalg.norm(moved[:, None, :] - trees[None, :, :2], axis=2)
        cost = np.where(d <= gate, d, 1e6)
        rows, cols = linear_sum_assignment(cost)
        ok = cost[rows, cols] < 1e6
        pairs = (tuple(rows[ok]), tuple(cols[ok]))
        used = len(pairs[0])
        if used < 2 or pairs == previous:
            break
        r, t = fit_rigid_2d(features[rows[ok], :2], trees[cols[ok], :2])
        previous = pairs
    return r, t, used


def _pair_hypotheses(features, trees, gate, max_points=60):
    """Rigid transforms that put a pair of map features on a pair of true landmarks as far apart (within ``gate``),
    both ways round: (k, 2, 2) rotations and (k, 2) translations. At most ``max_points`` points of each side take
    part (evenly spaced by index: deterministic)."""
    def subset(n):
        return np.unique(np.linspace(0, n - 1, min(n, max_points)).round().astype(int))
    fi, ti = subset(len(features)), subset(len(trees))
    f, g = features[fi, :2], trees[ti, :2]
    a, b = np.triu_indices(len(f), 1)
    c, d = np.triu_indices(len(g), 1)
    df = np.linalg.norm(f[a] - f[b], axis=1)
    dt = np.linalg.norm(g[c] - g[d], axis=1)
    order = np.argsort(dt)
    dt_sorted = dt[order]
    src, dst = [], []
    for k in range(len(df)):
        if df[k] < 2.0 * gate:  # too short to give a heading
            continue
        lo, hi = np.searchsorted(dt_sorted, [df[k] - gate, df[k] + gate])
        for m in order[lo:hi]:
            src.append((a[k], b[k]))
            dst.append((c[m], d[m]))
            dst.append((d[m], c[m]))
            src.append((a[k], b[k]))
    if not src:
        return np.zeros((0, 2, 2)), np.zeros((0, 2))
    src, dst = np.array(src), np.array(dst)
    p0, p1 = f[src[:, 0]], f[src[:, 1]]
    q0, q1 = g[dst[:, 0]], g[dst[:, 1]]
    angle = np.arctan2(*(q1 - q0)[:, ::-1].T) - np.arctan2(*(p1 - p0)[:, ::-1].T)
    cos, sin = np.cos(angle), np.sin(angle)
    rot = np.stack([np.stack([cos, -sin], 1), np.stack([sin, cos], 1)], 1)
    mid_p, mid_q = 0.5 * (p0 + p1), 0.5 * (q0 + q1)
    trans = mid_q - np.einsum('kij,kj->ki', rot, mid_p)
    return rot, trans


def fit_map_rigid(features, trees, gate=0.5, feature_ids=None, tree_ids=None, max_hypotheses=200000):
    """A rigid 2D transform (R, t) that moves a map (n, 3: x, y, r) onto the true landmarks (m, 3), for a run
    without a reference path, found wherever the map's frame lies: every pair of map features put on every pair of
    true landmarks as far apart (within ``gate``), and, where both sides carry ids (known association: the map's
    ids are the truth's), the fit over the shared ids; the hypothesis under which most features lie within ``gate``
    of a true landmark is refined by one-to-one matching (optimal assignment) and fitting until the matches stay the
    same. Returns (R, t, matches of the last fit); (identity, zero, 0) when nothing matches. A caller must not call
    a fit over fewer than MIN_MAP_FIT_MATCHES matches a score."""
    from scipy.spatial import cKDTree
    r0, t0 = np.eye(2), np.zeros(2)
    if len(features) < 2 or len(trees) < 2:
        return r0, t0, 0
    rots, trans = _pair_hypotheses(features, trees, gate)
    hyp_r, hyp_t = [r0], [t0]  # the map's own frame is a hypothesis too
    if feature_ids is not None and tree_ids is not None:
        index = {int(i): k for k, i in enumerate(tree_ids) if i >= 0}
        shared = [(j, index[int(i)]) for j, i in enumerate(feature_ids) if int(i) in index]
        if len(shared) >= MIN_MAP_FIT_MATCHES:
            fj, tj = zip(*shared)
            r, t = fit_rigid_2d(features[list(fj), :2], trees[list(tj), :2])
            hyp_r.append(r)
            hyp_t.append(t)
    rots = np.concatenate([np.array(hyp_r), rots[:max_hypotheses]])
    trans = np.concatenate([np.array(hyp_t), trans[:max_hypotheses]])
    tree = cKDTree(trees[:, :2])
    with_ids = feature_ids is not None and tree_ids is not None
    best, best_key = 0, None
    for start in range(0, len(rots), 5000):  # bounded memory
        r, t = rots[start:start + 5000], trans[start:start + 5000]
        moved = np.einsum('kij,nj->kni', r, features[:, :2]) + t[:, None, :]
        dist, nearest = tree.query(moved.reshape(-1, 2), distance_upper_bound=gate)
        dist = dist.reshape(len(r), len(features))
        inside = np.isfinite(dist)
        count = inside.sum(axis=1)
        # Most features on a landmark; then most of them on the landmark of their own id; then the closest.
        agree = np.zeros(len(r), dtype=int)
        if with_ids:
            nearest = np.minimum(nearest.reshape(len(r), len(features)), len(trees) - 1)
            agree = (inside & (np.asarray(tree_ids)[nearest] == np.asarray(feature_ids)[None, :])).sum(axis=1)
        spread = np.where(inside, dist, 0.0).sum(axis=1)
        for k in np.lexsort((spread, -agree, -count))[:1]:
            key = (int(count[k]), int(agree[k]), -float(spread[k]))
            if best_key is None or key > best_key:
                best, best_key = start + int(k), key
    if best_key[0] == 0:
        return r0, t0, 0
    return _refine_map_fit(features, trees, rots[best], trans[best], gate)


def _transform_info(r, t):
    return {'rotation_deg': math.degrees(math.atan2(r[1, 0], r[0, 0])), 'translation': [float(t[0]), float(t[1])]}


def _moved_map(features, r, t):
    moved = features.copy()
    if len(moved):
        moved[:, :2] = features[:, :2] @ r.T + t
    return moved


def _path_metrics(run, rt, rxy, ryaw, point_offset, fit, rpe_distance):
    """The path metrics of one trajectory (t, xy, yaw) against the reference positions rxy at the times rt
    (headings ryaw or None), after a rigid fit or none. Returns (metrics, (R, t, moved points, errors))."""
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
    # The run put on the reference at the first compared pose, position and heading (needs the headings).
    first = first_pose_rmse(pts, yaw, rxy, ryaw) if ryaw is not None else None
    metrics = {'path_rms': float(np.sqrt(np.mean(err ** 2))), 'path_rms_first_pose': first,
               'final_error': float(err[-1]),
               'path_rms_similarity': float(np.sqrt(np.mean(err_scaled ** 2))), 'similarity_scale': sc,
               'max_error': float(err.max()), 'rpe_translation': t_rpe, 'rpe_rotation_deg': r_rpe,
               'rpe_pairs': pairs, 'transform': _transform_info(r, t)}
    return metrics, (r, t, moved, err)


def evaluate(est, odom, ref_t, ref_xy, ref_yaw=None, truth_map=None, features=None, point_offset=(0.0, 0.0),
             fit=True, gate=0.5, rpe_distance=1.0, no_fit_too=False, feature_ids=None, truth_ids=None):
    """Every metric of one run. est / odom: (t, xy, yaw) as read_tum returns them; ref_t, ref_xy, ref_yaw the
    reference path (ref_yaw None: positions only, e.g. GPS), compared at its stamps inside the estimate's
    time span (the estimate interpolated there). The map (features (n, 3)) is scored against truth_map (m, 3),
    moved by the estimate's fit. Without a reference path (ref_t None) the map alone is scored, fitted onto
    the true landmarks by fit_map_rigid when ``fit`` (feature_ids / truth_ids: the map's and the truth's landmark
    ids, where known, one more hypothesis of the fit).

    With ``no_fit_too`` (and ``fit``) summary['no_fit'] holds the same figures without a fit (the run's frame
    taken as the reference's: the start pose known). Returns (summary, transforms, (reference t, xy) or None).
    """
    if ref_t is None:
        return _evaluate_map_alone(est, truth_map, features, point_offset, fit, gate, no_fit_too, feature_ids,
                                   truth_ids)
    ref_t = np.asarray(ref_t, float)
    sel = (ref_t >= est[0][0]) & (ref_t <= est[0][-1])
    if sel.sum() < 2:
        raise ValueError('the estimate (%.3f .. %.3f s) does not overlap the reference (%.3f .. %.3f s): %d of %d '
                         'reference stamps inside it, 2 needed'
                         % (est[0][0], est[0][-1], ref_t[0], ref_t[-1], int(sel.sum()), len(ref_t)))
    rt, rxy = ref_t[sel], ref_xy[sel]
    ryaw = ref_yaw[sel] if ref_yaw is not None else None
    summary = {'reference_poses': int(sel.sum()), 'reference_total': int(len(ref_t)),
               'fit': 'rigid_2d' if fit else 'none', 'point_offset': list(point_offset)}
    transforms = {}
    no_fit = {} if fit and no_fit_too else None
    for name, run in (('estimate', est), ('odometry', odom)):
        if run is None:
            continue
        summary[name], transforms[name] = _path_metrics(run, rt, rxy, ryaw, point_offset, fit, rpe_distance)
        if no_fit is not None:
            no_fit[name] = _path_metrics(run, rt, rxy, ryaw, point_offset, False, rpe_distance)[0]
    if truth_map is not None and features is not None:
        r, t = transforms['estimate'][:2]
        transforms['map'] = _moved_map(features, r, t)
        summary['map'] = score_map(transforms['map'], truth_map, gate)
        if no_fit is not None:
            no_fit['map'] = score_map(features, truth_map, gate)
    if no_fit is not None:
        summary['no_fit'] = no_fit
    return summary, transforms, (rt, rxy)


def _evaluate_map_alone(est, truth_map, features, point_offset, fit, gate, no_fit_too, feature_ids=None,
                        truth_ids=None):
    """evaluate without a reference path: the map against the true landmarks, after fit_map_rigid or none. A fit
    over fewer than MIN_MAP_FIT_MATCHES matches is refused: the map is then scored in its own frame (said)."""
    if truth_map is None or features is None:
        raise ValueError('nothing to score: no reference path, and %s'
                         % ('no true landmarks' if truth_map is None else 'no map of the run'))
    summary = {'reference_poses': 0, 'reference_total': 0, 'fit': 'map_rigid_2d' if fit else 'none',
               'point_offset': list(point_offset)}
    r, t, used = (fit_map_rigid(features, truth_map, gate, feature_ids, truth_ids) if fit
                  else (np.eye(2), np.zeros(2), 0))
    if fit:
        summary['map_fit'] = dict(_transform_info(r, t), matches=int(used))
        if used < MIN_MAP_FIT_MATCHES:
            summary['fit'] = 'none'  # a fit over 2 points fits any 2 points: no score
            summary['map_fit']['refused'] = True
            r, t = np.eye(2), np.zeros(2)
    transforms = {'map': _moved_map(features, r, t)}
    pts = point_of(est[1], est[2], point_offset)
    transforms['estimate'] = (r, t, pts @ r.T + t, None)
    summary['map'] = score_map(transforms['map'], truth_map, gate)
    if fit and no_fit_too:
        summary['no_fit'] = {'map': score_map(features, truth_map, gate)}
    return summary, transforms, None


#: chi-square quantile of 95 % with 2 degrees of freedom: a position inside the region of a Gaussian.
CHI2_2DOF_95 = 5.991


def read_updates_csv(path):
    """The run's updates.csv (slam_bag --out, the node's run folder): a dict of columns (numpy arrays) with
    'stamp', 'health', 'health_cause' (strings; the cause empty where the run did not write it) and, where the run
    wrote them, the particle cloud's 'cloud_x', 'cloud_y',
    'cloud_xx', 'cloud_xy', 'cloud_yy' (NaN for updates that took no sweep) and the published estimate's
    'estimate_x', 'estimate_y', 'estimate_xx', 'estimate_xy', 'estimate_yy' (NaN where not written). None when
    the file is missing."""
    if not os.path.exists(path):
        return None
    with open(path, newline='') as f:
        rows = list(csv.DictReader(f))
    out = {'stamp': np.array([float(r['stamp']) for r in rows]),
           'health': [r.get('health', '') for r in rows],
           'health_cause': [r.get('health_cause') or '' for r in rows]}
    for k in ('cloud_x', 'cloud_y', 'cloud_xx', 'cloud_xy', 'cloud_yy',
              'estimate_x', 'estimate_y', 'estimate_xx', 'estimate_xy', 'estimate_yy'):
        out[k] = np.array([float(r[k]) if r.get(k) not in (None, '') else float('nan') for r in rows])
    return out


def coverage_95(updates, ref_t, ref_xy, r=None, t=None, region='estimate'):
    """Share of the reference positions that lie inside the 95 % region of the update nearest in time (its position
    and covariance, moved by the rigid fit r, t when given): the published estimate's (region 'estimate', what the
    robot is told: its pose and the covariance published with it) or the particle cloud's ('cloud'). Returns
    (share, compared) or (None, 0) when the run wrote no such region."""
    if updates is None or region + '_xx' not in updates or not np.isfinite(updates[region + '_xx']).any():
        return None, 0
    ok = np.isfinite(updates[region + '_xx'])
    st = updates['stamp'][ok]
    mean = np.column_stack([updates[region + '_x'][ok], updates[region + '_y'][ok]])
    cov = np.stack([np.column_stack([updates[region + '_xx'][ok], updates[region + '_xy'][ok]]),
                    np.column_stack([updates[region + '_xy'][ok], updates[region + '_yy'][ok]])], axis=1)
    r = np.eye(2) if r is None else np.asarray(r)
    t = np.zeros(2) if t is None else np.asarray(t)
    inside = 0
    compared = 0
    for tq, p in zip(ref_t, ref_xy):
        i = int(np.searchsorted(st, tq))
        cand = [j for j in (i - 1, i) if 0 <= j < len(st)]
        if not cand:
            continue
        j = min(cand, key=lambda k: abs(st[k] - tq))
        m = r @ mean[j] + t
        c = r @ cov[j] @ r.T
        d = p - m
        compared += 1
        det = np.linalg.det(c)
        if det > 0 and float(d @ np.linalg.solve(c, d)) <= CHI2_2DOF_95:
            inside += 1
    return (inside / compared if compared else None), compared
