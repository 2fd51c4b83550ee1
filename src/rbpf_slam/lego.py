"""Claus Brenner's LEGO robot logs (SLAM lectures, Leibniz Universitaet Hannover) to a rosbag.

Files (text, mm and rad, CRLF line ends are fine), in one directory:

* ``robot4_motors.txt``: ``M ts left ... right ...``: the left track's cumulative ticks are field 2,
  the right track's field 6 (counting ``M`` as field 0). Odometry is integrated from them (exact arcs
  of a differential drive). Records that repeat the stamp of the one before are merged into it (the
  ticks are cumulative, so no motion is lost).
* ``robot4_scan.txt``: ``S ts n r0 ... r(n-1)``: ranges in mm, counter-clockwise. Written as
  sensor_msgs/LaserScan in metres in the scanner's own frame ``laser``: beam i at
  (i - n/2) * 0.006135923151543 rad; the scanner is mounted 30 mm ahead of the robot centre and turned
  by -0.0698132 rad (4 degrees), which is the ``base_link -> laser`` transform on ``/tf_static`` (so
  beam i has the bearing (i - 330) * 0.006135923151543 - 0.0698132 in the robot frame, as the
  data set states it). Ranges below 20 mm are invalid: NaN, with range_min 0.02 m (REP-117). A scan shows the arena
  ``scan_latency`` (config/lego/robot.yaml) before its log stamp: the scans keep their log stamps and the
  odometry and the reference are stamped that much after theirs.
* ``robot4_reference.txt``: ``P ts x y``, the robot position seen by an overhead camera: ground truth,
  on ``ground_truth/odom`` (child frame ``laser_truth``: the points are compared with the scanner's
  position; positions only, the orientation is identity) and ``ground_truth/path``.
* ``robot_arena_landmarks.txt``: ``L C x y r``, the true cylinders: ``ground_truth/landmarks``
  (rbpf_slam/TrunkArray with their radius and index as id, latched).

Calibration constants of the data set (0.349 mm of track per tick, track width 155 mm, scanner 30 mm ahead
of the robot centre, start pose of the scanner (1850 mm, 1897 mm, 213 deg) in the arena, ...) are stated
once, in config/lego/robot.yaml, which lego_trunks reads too; :func:`read_robot` loads it.

Frames: odometry starts at the identity (``odom`` = where the robot starts). The truth is expressed in
``map`` = the robot centre's start pose (``--truth-frame start``, the default: the frame where a SLAM
map starts, as in the simulator; the first reference point is then at the scanner, (0.03, 0)), or in
the arena's own coordinates (``--truth-frame arena``). Stamps: the logs' milliseconds as seconds (plus
``scan_latency`` for the odometry and the reference).
"""
import math
import os

import numpy as np

from rbpf_slam import convert_common as cc

#: The robot's constants (metres, radians): config/lego/robot.yaml of this package.
ROBOT_FILE = os.path.join('config', 'lego', 'robot.yaml')

_ROBOT_KEYS = ('tick', 'track', 'scanner_x', 'scanner_yaw', 'beam_increment', 'range_min', 'range_max',
               'start_scanner_pose', 'cylinder_radius')
#: Optional constants and their defaults.
_ROBOT_OPTIONAL = {'scan_latency': 0.0}


def robot_file():
    """Path of config/lego/robot.yaml: in the source tree beside this module, else in the package's share
    folder (rospkg)."""
    here = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', ROBOT_FILE))
    if os.path.exists(here):
        return here
    import rospkg
    return os.path.join(rospkg.RosPack().get_path('rbpf_slam'), ROBOT_FILE)


def read_robot(path=None):
    """The LEGO robot's constants as a dict (the keys of config/lego/robot.yaml; start_scanner_pose as a tuple
    x [m], y [m], yaw [rad]). A missing key or value that is not a number is a ValueError naming the file."""
    import yaml
    path = path or robot_file()
    with open(path) as f:
        data = yaml.safe_load(f) or {}
    missing = [k for k in _ROBOT_KEYS if k not in data]
    optional = {k: data.get(k, v) for k, v in _ROBOT_OPTIONAL.items()}
    if missing:
        raise ValueError('%s: missing key(s) %s' % (path, ', '.join(missing)))
    try:
        robot = {k: float(data[k]) for k in _ROBOT_KEYS if k != 'start_scanner_pose'}
        robot.update({k: float(v) for k, v in optional.items()})
        pose = data['start_scanner_pose']
        robot['start_scanner_pose'] = (float(pose['x']), float(pose['y']), math.radians(float(pose['yaw_deg'])))
    except (TypeError, KeyError, ValueError) as e:
        raise ValueError('%s: a value is not a number or start_scanner_pose lacks x, y, yaw_deg (%s)' % (path, e))
    return robot


_ROBOT = read_robot()
TICK = _ROBOT['tick']                       # [m] of track per motor tick
TRACK = _ROBOT['track']                     # [m] track width
SCANNER_X = _ROBOT['scanner_x']             # [m] scanner ahead of the robot centre
SCANNER_YAW = _ROBOT['scanner_yaw']         # [rad] scanner mounting angle
BEAM_INCREMENT = _ROBOT['beam_increment']   # [rad]
RANGE_MIN = _ROBOT['range_min']             # [m] readings below are invalid
RANGE_MAX = _ROBOT['range_max']             # [m]
START_SCANNER_POSE = _ROBOT['start_scanner_pose']  # [m, m, rad] in the arena
CYLINDER_RADIUS = _ROBOT['cylinder_radius']  # [m] nominal; the landmark file states each radius
SCAN_LATENCY = _ROBOT['scan_latency']       # [s] a scan shows the world this long before its log stamp

EXAMPLE = """
Example:
  lego_to_bag $RBPF_SLAM_DATA/brenner_lego -o lego.bag
  rosbag play --clock lego.bag     # /odom, /tf, /tf_static, /scan, /ground_truth/{odom,path,landmarks}
"""


def _records(path, tag, bad, limit):
    """(line, tokens) of the lines starting with ``tag``; other first tokens are malformed."""
    n = 0
    for line, tokens in cc.read_tokens(path):
        if tokens[0] != tag:
            bad(cc.ConversionError(path, line, 'a line starting with %r' % tag, got=cc.quote(tokens[0])))
            continue
        yield line, tokens
        n += 1
        if limit is not None and n >= limit:
            return


def _empty(path, what):
    return cc.ConversionError(path, None, what, got='an empty file')


def read_motors(path, bad=None, limit=None):
    """Motor records: arrays (stamp [s], left ticks, right ticks), cumulative ticks."""
    bad = bad or cc.BadLines()
    rows = []
    for line, tokens in _records(path, 'M', bad, limit):
        try:
            cc.require_fields(tokens, 7, path, line, 'M ts left_ticks ... right_ticks (at least', exact=False)
            v = cc.parse_ints([tokens[1], tokens[2], tokens[6]], path, line,
                              'integers as the time stamp and the tick counts (fields 1, 2, 6)')
            rows.append(v)
        except cc.ConversionError as e:
            bad(e)
    if not rows:
        raise _empty(path, 'motor records "M ts left ... right ..."')
    a = np.array(rows, dtype=np.int64)
    return a[:, 0] / 1000.0, a[:, 1], a[:, 2]


def read_scans(path, bad=None, limit=None):
    """Scan records: (stamps [s], ranges [mm] as an (N, n) array)."""
    bad = bad or cc.BadLines()
    stamps, scans = [], []
    width = None
    for line, tokens in _records(path, 'S', bad, limit):
        try:
            cc.require_fields(tokens, 3, path, line, 'S ts n r0 ... (at least', exact=False)
            head = cc.parse_ints(tokens[1:3], path, line, 'integers as the time stamp and the number of ranges')
            n = int(head[1])
            cc.require_fields(tokens, 3 + n, path, line, 'S ts n and %d ranges' % n)
            if width is not None and n != width:
                raise cc.ConversionError(path, line, '%d ranges as in the scans before' % width, got=n)
            r = cc.parse_floats(tokens[3:], path, line, 'numbers as ranges [mm]')
            width = n
            stamps.append(head[0] / 1000.0)
            scans.append(r)
        except cc.ConversionError as e:
            bad(e)
    if not scans:
        raise _empty(path, 'scan records "S ts n r0 ..."')
    return np.array(stamps), np.array(scans)


def read_reference(path, bad=None, limit=None):
    """Reference positions: (stamps [s], x [m], y [m]) in the arena."""
    bad = bad or cc.BadLines()
    rows = []
    for line, tokens in _records(path, 'P', bad, limit):
        try:
            cc.require_fields(tokens, 4, path, line, 'P ts x y')
            rows.append(cc.parse_floats(tokens[1:4], path, line, 'numbers as ts x y'))
        except cc.ConversionError as e:
            bad(e)
    if not rows:
        raise _empty(path, 'reference records "P ts x y"')
    a = np.array(rows)
    return a[:, 0] / 1000.0, a[:, 1] / 1000.0, a[:, 2] / 1000.0


def read_landmarks(path, bad=None):
    """True cylinders: (x, y, radius) [m] in the arena, an (N, 3) array."""
    bad = bad or cc.BadLines()
    rows = []
    for line, tokens in _records(path, 'L', bad, None):
        try:
            cc.require_fields(tokens, 5, path, line, 'L C x y r')
            if tokens[1] != 'C':
                raise cc.ConversionError(path, line, "landmark type 'C' (cylinder)", got=cc.quote(tokens[1]))
            rows.append(cc.parse_floats(tokens[2:5], path, line, 'numbers as x y r'))
        except cc.ConversionError as e:
            bad(e)
    if not rows:
        raise _empty(path, 'landmark records "L C x y r"')
    return np.array(rows) / 1000.0


def merge_repeated_stamps(stamps, *columns):
    """Keep the last record of each run of equal stamps (for cumulative data). Returns (indices kept,
    stamps, columns...)."""
    keep = cc.last_of_equal_runs(stamps)
    return (keep, np.asarray(stamps)[keep]) + tuple(np.asarray(c)[keep] for c in columns)


def odometry_from_ticks(left, right, tick=TICK, track=TRACK):
    """Robot-centre poses (x, y, theta arrays) after each record, from cumulative track ticks; the first
    record is the start (identity)."""
    dl = np.diff(np.asarray(left, dtype=float), prepend=float(left[0])) * tick
    dr = np.diff(np.asarray(right, dtype=float), prepend=float(right[0])) * tick
    ds, dth = cc.diff_drive_steps(dl, dr, track)
    x, y, th = cc.integrate_arcs(ds, dth)
    return x, y, th, ds, dth


def start_robot_pose(scanner_pose=START_SCANNER_POSE, scanner_x=SCANNER_X):
    """The robot centre's start pose in the arena, from the scanner's."""
    x, y, th = scanner_pose
    return (x - scanner_x * math.cos(th), y - scanner_x * math.sin(th), th)


def arena_to_start(x, y, start=None):
    """Arena points expressed in the frame of the robot centre's start pose."""
    sx, sy, sth = start if start is not None else start_robot_pose()
    c, s = math.cos(sth), math.sin(sth)
    dx, dy = np.asarray(x) - sx, np.asarray(y) - sy
    return c * dx + s * dy, -s * dx + c * dy


def scan_to_rep117(ranges_mm):
    """Ranges [mm] to metres, readings below 20 mm invalid (NaN)."""
    r = np.asarray(ranges_mm, dtype=float) / 1000.0
    return np.where(r < RANGE_MIN, np.nan, r)


def build_parser():
    p = cc.make_parser('lego_to_bag', __doc__)
    p.add_argument('directory', help='directory of the logs')
    p.add_argument('--prefix', default='robot4', help='log name prefix: PREFIX_motors.txt, ... (default robot4)')
    p.add_argument('--motors', help='motor log (default DIRECTORY/PREFIX_motors.txt)')
    p.add_argument('--scan', help='scan log (default DIRECTORY/PREFIX_scan.txt)')
    p.add_argument('--reference', help='reference positions (default DIRECTORY/PREFIX_reference.txt; optional)')
    p.add_argument('--landmarks', help='true cylinders (default DIRECTORY/robot_arena_landmarks.txt; optional)')
    p.add_argument('--truth-frame', choices=('start', 'arena'), default='start',
                   help='express the truth in the robot\'s start frame (default) or in arena coordinates')
    cc.add_common_arguments(
        p,
        topics=(('--odom-topic', 'odom', 'nav_msgs/Odometry'),
                ('--scan-topic', 'scan', 'sensor_msgs/LaserScan'),
                ('--truth-odom-topic', 'ground_truth/odom', 'nav_msgs/Odometry, the reference positions'),
                ('--truth-path-topic', 'ground_truth/path', 'nav_msgs/Path, all reference positions (once, at the '
                 'end)'),
                ('--truth-landmarks-topic', 'ground_truth/landmarks', 'rbpf_slam/TrunkArray, the true cylinders')),
        frames=(('--odom-frame', 'odom', 'odometry frame'),
                ('--base-frame', 'base_link', 'robot frame (the centre between the tracks)'),
                ('--laser-frame', 'laser', 'scanner frame'),
                ('--map-frame', 'map', 'frame of the truth'),
                ('--truth-point-frame', 'laser_truth', 'child frame of the reference positions')))
    p.epilog = 'A record for --limit is a line of each log.' + '\n' + EXAMPLE
    return p


def _path_of(args, explicit, suffix, shared=False):
    if explicit:
        return explicit
    name = suffix if shared else '%s_%s' % (args.prefix, suffix)
    return os.path.join(args.directory, name)


def convert(args, out, bad, summary):
    from rbpf_slam import convert_msgs as m
    motors_path = _path_of(args, args.motors, 'motors.txt')
    scan_path = _path_of(args, args.scan, 'scan.txt')
    ref_path = _path_of(args, args.reference, 'reference.txt')
    lm_path = _path_of(args, args.landmarks, 'robot_arena_landmarks.txt', shared=True)
    for path in (motors_path, scan_path):  # both before reading either
        cc.input_file(path)

    t_m, left, right = read_motors(motors_path, bad, args.limit)
    n_read = len(t_m)
    keep, t_m, left, right = merge_repeated_stamps(t_m, left, right)
    summary.skip('motor records repeating the stamp of the one before (merged: ticks are cumulative)',
                 n_read - len(keep))
    t_m = t_m + SCAN_LATENCY  # see the scans below
    x, y, th, ds, dth = odometry_from_ticks(left, right)
    dt = np.diff(t_m, prepend=t_m[0])
    safe_dt = np.where(dt > 0, dt, 1.0)
    v = np.where(dt > 0, ds / safe_dt, 0.0)
    w = np.where(dt > 0, dth / safe_dt, 0.0)

    t_s, scans = read_scans(scan_path, bad, args.limit)
    n_read = len(t_s)
    keep_s, t_s, scans = merge_repeated_stamps(t_s, scans)
    summary.skip('scans repeating the stamp of the one before (the later kept)', n_read - len(keep_s))
    if SCAN_LATENCY:
        # A scan shows the arena SCAN_LATENCY before its log stamp (robot.yaml: scan_latency). ROS stamps are positive,
        # so the scans keep their log stamps and the streams stamped when they happened (ticks, camera) move later.
        summary.note('odometry and reference stamped %.3f s after their log stamps: the scans\' latency'
                     % SCAN_LATENCY)
    n_beams = scans.shape[1]
    angle_min = -(n_beams // 2) * BEAM_INCREMENT
    invalid = int(np.sum(scans < RANGE_MIN * 1000.0))
    summary.note('%d of %d readings below 20 mm written as NaN (invalid)' % (invalid, scans.size))

    truth_start = start_robot_pose()
    to_map = (lambda px, py: arena_to_start(px, py, truth_start)) if args.truth_frame == 'start' else \
        (lambda px, py: (np.asarray(px), np.asarray(py)))
    ref = None
    if args.reference or os.path.exists(ref_path):
        t_r, rx, ry = read_reference(ref_path, bad, args.limit)
        n_read = len(t_r)
        keep_r, t_r, rx, ry = merge_repeated_stamps(t_r, rx, ry)
        t_r = t_r + SCAN_LATENCY  # the camera's time, as the ticks'
        summary.skip('reference positions repeating the stamp of the one before (the later kept)',
                     n_read - len(keep_r))
        ref = (t_r,) + tuple(to_map(rx, ry))
    else:
        summary.note('no reference file (%s): no ground_truth/odom, ground_truth/path' % ref_path)
    landmarks = None
    if args.landmarks or os.path.exists(lm_path):
        landmarks = read_landmarks(lm_path, bad)
        lx, ly = to_map(landmarks[:, 0], landmarks[:, 1])
        landmarks = np.column_stack([lx, ly, landmarks[:, 2]])
    else:
        summary.note('no landmark file (%s): no ground-truth landmarks' % lm_path)
    summary.note('truth in the %s frame %r (robot centre start pose in the arena: %.4f m, %.4f m, %.2f deg)' % (
        'start' if args.truth_frame == 'start' else 'arena', args.map_frame, truth_start[0], truth_start[1],
        math.degrees(truth_start[2])))

    t0 = float(min(t_m[0], t_s[0], ref[0][0] if ref is not None else np.inf))
    out.expect(2 * len(t_m) + len(t_s) + 1 + (len(ref[0]) + 1 if ref is not None else 0) + (landmarks is not None))

    def statics():
        yield t0, '/tf_static', m.tf_message(m.transform(t0, args.base_frame, args.laser_frame, SCANNER_X, 0.0,
                                                         SCANNER_YAW)), True
        if landmarks is not None:
            trunks = [m.trunk(float(lx), float(ly), radius=float(r), landmark_id=i)
                      for i, (lx, ly, r) in enumerate(landmarks)]
            yield t0, args.truth_landmarks_topic, m.trunk_array(t0, args.map_frame, trunks), True

    def odometry():
        for i in range(len(t_m)):
            t = float(t_m[i])
            yield t, args.odom_topic, m.odometry(t, args.odom_frame, args.base_frame, float(x[i]), float(y[i]),
                                                 float(th[i]), float(v[i]), float(w[i])), False
            yield t, '/tf', m.tf_message(m.transform(t, args.odom_frame, args.base_frame, float(x[i]), float(y[i]),
                                                     float(th[i]))), False

    def laser():
        for i in range(len(t_s)):
            t = float(t_s[i])
            yield t, args.scan_topic, m.laser_scan(t, args.laser_frame, angle_min, BEAM_INCREMENT,
                                                   scan_to_rep117(scans[i]).tolist(), RANGE_MIN, RANGE_MAX), False

    def truth():
        if ref is not None:
            yield from cc.position_reference(args, *ref)

    out.write_merged([statics(), odometry(), laser(), truth()])


def main(argv=None):
    return cc.run(build_parser(), convert, argv)
