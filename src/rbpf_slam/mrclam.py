"""The UTIAS Multi-Robot Cooperative Localization and Mapping data set (MR.CLAM; Leung, Halpern, Barfoot and Liu,
University of Toronto, 2011) to a rosbag: one robot's commanded velocities and landmark readings, with the Vicon
truth of its path and of the landmarks.

Files in one folder (gzipped or plain; ``#`` lines are comments, as in the original release's headers), for robot N:

* ``RobotN_Odometry.dat``: ``time v w``: the **commanded** forward [m/s] and angular [rad/s] velocities, not
  measured wheel motion. Integrated as logged: each line's command held until the next line's time (a unicycle,
  exact arcs), from the identity at the first line: ``odom`` (nav_msgs/Odometry) and TF ``odom -> base_link`` at
  every line. The twist of each message is the command over the step ending at its stamp (0 for the first), so
  a velocity motion model reads its control there.
* ``RobotN_Measurement.dat``: ``time barcode range bearing``: the camera's readings of barcodes [m, rad]. A
  barcode is mapped to its subject by ``Barcodes.dat`` (``subject barcode``). Subjects 1-5 are the robots, not
  landmarks: their readings are dropped and counted; a barcode that Barcodes.dat does not list is a misread,
  skipped and counted. The readings of one time form one ``landmarks`` rbpf_slam/TrunkArray in ``base_link``
  (the camera's place on the robot is not documented: taken as base_link), empty where all were of robots:
  centre (r cos b, r sin b), radius 0 (unknown), METHOD_GIVEN, id = the subject (6-20; the barcode is read by
  the camera, so this association is measured, not given from the truth; ``--no-ids`` writes -1), the covariance
  of the centre from ``--range-sigma`` 0.15 m and ``--bearing-sigma`` 0.03 rad (round figures near the robust
  spread of Dataset 1's readings about the Vicon truth: 0.11-0.19 m, 0.007-0.03 rad). Each array states the
  camera's scope: 0 to ``--max-range`` 5 m, bearings within ``--fov`` +-30 deg (its field of view; the summary
  counts the readings beyond either), detection probability not known (0).
* ``RobotN_Groundtruth.dat`` (optional): ``time x y theta`` from Vicon: the reference, ``ground_truth/odom``
  (child frame ``base_link_truth``) and ``ground_truth/path`` (latched) in the frame ``map``.
* ``Landmark_Groundtruth.dat`` (optional): ``subject x y sigma_x sigma_y``: ``ground_truth/landmarks``
  (TrunkArray in ``map``, latched; id = subject, radius 0, covariance diag(sigma_x^2, sigma_y^2)).

Frames: the truth is expressed in ``map`` = the robot's Vicon pose at the first odometry stamp
(``--truth-frame start``, the default: odom and map then coincide at the start, as in the simulator) or in the
room's Vicon coordinates (``--truth-frame room``).

Stamps are the files' own (from 0 in the redistributed files, Unix seconds in the original release; files of
both kinds together are refused) plus ``--time-offset``, by default 1 s (ROS time 0 is no time: rosbag refuses it,
TF reads it as "the latest"). The redistributed files print stamps with five significant digits, so from
1000 s on five 50 Hz odometry and truth lines share each printed 0.1 s: runs of equal stamps in those two files
are spread out again by line number (convert_common.spread_equal_stamps; the summary says how many and by how
much). Readings are grouped by their printed stamp; readings timed outside the odometry are skipped.
"""
import argparse
import math
import os

import numpy as np

from rbpf_slam import convert_common as cc

ROBOT_SUBJECTS = frozenset(range(1, 6))  # subjects 1-5 are the robots; landmarks are 6 and up
CAMERA_HALF_FOV = math.radians(30.0)     # [rad] the camera sees bearings within +-30 deg
CAMERA_MAX_RANGE = 5.0                   # [m] barcodes are read out to about 5 m
RANGE_SIGMA = 0.15                       # [m]
BEARING_SIGMA = 0.03                     # [rad]
#: Commands beyond these are no command of the data set's iRobot Creates (0.5 m/s at most; the logs' largest are
#: 0.09 m/s and 0.57 rad/s).
MAX_SPEED = 2.0                          # [m/s]
MAX_TURN_RATE = 2.0 * math.pi            # [rad/s]

EXAMPLE = """
Example:
  mrclam_to_bag $RBPF_SLAM_DATA/mrclam --robot 1 -o mrclam1.bag
  rosbag play --clock mrclam1.bag   # /odom, /tf, /landmarks, /ground_truth/{odom,path,landmarks}
"""


# --- Reading the files -----------------------------------------------------------------------------


def _whole(value):
    return float(value).is_integer()


def read_barcodes(path, bad=None):
    """Barcodes.dat: {barcode: subject}. A barcode or subject listed twice is malformed."""
    bad = bad or cc.BadLines()
    rows, lines = cc.read_table(path, ('subject', 'barcode'), bad)
    out, seen = {}, {}
    for (subject, barcode), line in zip(rows, lines):
        line = int(line)
        try:
            if not (_whole(subject) and _whole(barcode)) or subject < 1:
                raise cc.ConversionError(path, line, 'whole numbers as subject barcode (subjects from 1)',
                                         got='%g %g' % (subject, barcode))
            if int(barcode) in out or int(subject) in seen:
                twice = 'barcode %d' % barcode if int(barcode) in out else 'subject %d' % subject
                raise cc.ConversionError(path, line, 'each subject and barcode listed once',
                                         got='%s again (first on line %d)' % (
                                             twice, seen.get(int(subject), seen.get(out.get(int(barcode))))))
        except cc.ConversionError as e:
            bad(e)
            continue
        out[int(barcode)] = int(subject)
        seen[int(subject)] = line
    if not out:
        raise cc.ConversionError(path, None, 'lines of subject barcode', got='no valid line')
    return out


def read_landmarks(path, bad=None):
    """Landmark_Groundtruth.dat: an (n, 5) array subject, x, y, sigma_x, sigma_y [m]. A robot's subject (1-5), a
    subject listed twice or a negative sigma is malformed."""
    bad = bad or cc.BadLines()
    rows, lines = cc.read_table(path, ('subject', 'x', 'y', 'sigma_x', 'sigma_y'), bad)
    keep, seen = [], {}
    for k, (row, line) in enumerate(zip(rows, lines)):
        line = int(line)
        try:
            if not _whole(row[0]) or int(row[0]) in ROBOT_SUBJECTS or row[0] < 1:
                raise cc.ConversionError(path, line, 'a landmark subject (a whole number from %d; 1-%d are the '
                                         'robots)' % (max(ROBOT_SUBJECTS) + 1, max(ROBOT_SUBJECTS)),
                                         got='%g' % row[0])
            if int(row[0]) in seen:
                raise cc.ConversionError(path, line, 'each landmark listed once',
                                         got='subject %d again (first on line %d)' % (row[0], seen[int(row[0])]))
            if row[3] < 0 or row[4] < 0:
                raise cc.ConversionError(path, line, 'standard deviations >= 0', got='%g %g' % (row[3], row[4]))
        except cc.ConversionError as e:
            bad(e)
            continue
        seen[int(row[0])] = line
        keep.append(k)
    if not keep:
        raise cc.ConversionError(path, None, 'lines of subject x y sigma_x sigma_y', got='no valid line')
    return rows[keep]


def read_odometry(path, bad=None, limit=None):
    """RobotN_Odometry.dat: (stamps as printed, v [m/s], w [rad/s]); a command beyond MAX_SPEED or MAX_TURN_RATE
    is malformed."""
    bad = bad or cc.BadLines()
    rows, lines = cc.read_table(path, ('time', 'v', 'w'), bad, limit=limit, order='not decrease')
    v_ok = np.abs(rows[:, 1]) <= MAX_SPEED
    ok = v_ok & (np.abs(rows[:, 2]) <= MAX_TURN_RATE)
    for k in np.flatnonzero(~ok):
        if not v_ok[k]:
            bad(cc.ConversionError(path, int(lines[k]), 'a forward velocity within +-%g m/s' % MAX_SPEED,
                                   got='%g' % rows[k, 1]))
        else:
            bad(cc.ConversionError(path, int(lines[k]), 'an angular velocity within +-%.4g rad/s' % MAX_TURN_RATE,
                                   got='%g' % rows[k, 2]))
    rows = rows[ok]
    if not len(rows):
        raise cc.ConversionError(path, None, 'lines of time v w', got='no valid line')
    return rows[:, 0], rows[:, 1], rows[:, 2]


def read_measurements(path, bad=None, until=None):
    """RobotN_Measurement.dat: (an (n, 4) array time, barcode, range [m], bearing [rad]; the line of each row).
    A barcode that is not a whole number or a negative range is malformed."""
    bad = bad or cc.BadLines()
    rows, lines = cc.read_table(path, ('time', 'barcode', 'range', 'bearing'), bad, until=until,
                                order='not decrease')
    ok = np.ones(len(rows), dtype=bool)
    for k, (row, line) in enumerate(zip(rows, lines)):
        try:
            if not _whole(row[1]):
                raise cc.ConversionError(path, int(line), 'a whole number as the barcode', got='%g' % row[1])
            if row[2] < 0:
                raise cc.ConversionError(path, int(line), 'a range >= 0', got='%g' % row[2])
        except cc.ConversionError as e:
            bad(e)
            ok[k] = False
    return rows[ok], lines[ok]


def read_groundtruth(path, bad=None, until=None):
    """RobotN_Groundtruth.dat: (stamps as printed, x, y, theta)."""
    rows, _ = cc.read_table(path, ('time', 'x', 'y', 'theta'), bad, until=until, one_past=True,
                            order='not decrease')
    return rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3]


# --- The models ------------------------------------------------------------------------------------


def commanded_odometry(stamps, v, w):
    """Poses (x, y, theta) at each stamp from the commands held until the next stamp (a unicycle, exact arcs; the
    first pose the identity), and the command over the step ending at each stamp (v, w; 0 for the first)."""
    x, y, th, _, _ = cc.integrate_velocities(stamps, v, w)
    return x, y, th, np.r_[0.0, np.asarray(v, float)[:-1]], np.r_[0.0, np.asarray(w, float)[:-1]]


def pose_at(t, stamps, x, y, theta):
    """The pose at time t, interpolated (the heading unwrapped); clamped to the ends."""
    return (float(np.interp(t, stamps, x)), float(np.interp(t, stamps, y)),
            float(cc.wrap_angle(np.interp(t, stamps, np.unwrap(theta)))))


def to_frame(origin, x, y, theta=None):
    """Points (and headings) expressed in the frame of the pose ``origin`` (x, y, theta)."""
    ox, oy, oth = origin
    c, s = math.cos(oth), math.sin(oth)
    dx, dy = np.asarray(x, float) - ox, np.asarray(y, float) - oy
    if theta is None:
        return c * dx + s * dy, -s * dx + c * dy
    return c * dx + s * dy, -s * dx + c * dy, cc.wrap_angle(np.asarray(theta, float) - oth)


def landmark_readings(rows, barcodes):
    """Split readings (time, barcode, range, bearing) into those of landmarks, (time, subject, range, bearing),
    and counts of the dropped ones: ({robot subject: readings}, {unknown barcode: readings})."""
    subjects = np.array([barcodes.get(int(b), -1) for b in rows[:, 1]], dtype=int).reshape(-1)
    robots = np.isin(subjects, sorted(ROBOT_SUBJECTS))
    unknown = subjects < 0
    landmarks = rows[~robots & ~unknown].copy()
    landmarks[:, 1] = subjects[~robots & ~unknown]
    robot_counts = dict(zip(*np.unique(subjects[robots], return_counts=True)))
    unknown_counts = dict(zip(*np.unique(rows[unknown, 1].astype(int), return_counts=True)))
    return landmarks, robot_counts, unknown_counts


# --- The command -----------------------------------------------------------------------------------


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError('not a whole number: %r' % text)
    if value < 1:
        raise argparse.ArgumentTypeError('must be >= 1: %r' % text)
    return value


def build_parser():
    p = cc.make_parser('mrclam_to_bag', __doc__)
    p.add_argument('directory', help='folder of the data set\'s files (gzipped or plain)')
    p.add_argument('--robot', type=_positive_int, required=True, metavar='N', help='the robot (1-5 in the data set)')
    p.add_argument('--odometry', help='default DIRECTORY/RobotN_Odometry.dat[.gz]')
    p.add_argument('--measurements', help='default DIRECTORY/RobotN_Measurement.dat[.gz]')
    p.add_argument('--barcodes', help='default DIRECTORY/Barcodes.dat[.gz]')
    p.add_argument('--groundtruth', help='default DIRECTORY/RobotN_Groundtruth.dat[.gz] (optional)')
    p.add_argument('--landmarks', help='default DIRECTORY/Landmark_Groundtruth.dat[.gz] (optional)')
    p.add_argument('--truth-frame', choices=('start', 'room'), default='start',
                   help='express the truth in the robot\'s start frame (default) or in the room\'s Vicon frame')
    p.add_argument('--no-ids', action='store_true', help='write the readings with id -1 (unknown association)')
    p.add_argument('--range-sigma', type=cc.positive_float, default=RANGE_SIGMA,
                   help='range noise [m] (default %(default)s)')
    p.add_argument('--bearing-sigma', type=cc.positive_float, default=BEARING_SIGMA,
                   help='bearing noise [rad] (default %(default)s)')
    p.add_argument('--max-range', type=cc.positive_float, default=CAMERA_MAX_RANGE,
                   help='the camera\'s range [m] stated in every array (default %(default)s)')
    p.add_argument('--fov', type=cc.positive_float, default=math.degrees(CAMERA_HALF_FOV), metavar='DEG',
                   help='half the camera\'s field of view [deg] stated in every array (default %(default)g)')
    cc.add_common_arguments(
        p, time_offset=cc.ZERO_CLOCK_OFFSET,
        topics=(('--odom-topic', 'odom', 'nav_msgs/Odometry'),
                ('--landmarks-topic', 'landmarks', 'rbpf_slam/TrunkArray, the landmark readings of each time'),
                ('--truth-odom-topic', 'ground_truth/odom', 'nav_msgs/Odometry, the Vicon poses'),
                ('--truth-path-topic', 'ground_truth/path', 'nav_msgs/Path, all Vicon poses (once, at the end)'),
                ('--truth-landmarks-topic', 'ground_truth/landmarks', 'rbpf_slam/TrunkArray, the true landmarks')),
        frames=(('--odom-frame', 'odom', 'odometry frame'),
                ('--base-frame', 'base_link', 'robot frame, also of the readings'),
                ('--map-frame', 'map', 'frame of the truth'),
                ('--truth-base-frame', 'base_link_truth', 'child frame of the Vicon poses')))
    p.epilog = ('A record for --limit is an odometry line; the other files are read up to the last of those.\n'
                + EXAMPLE)
    return p


def _input(args, explicit, name, required=True):
    if explicit:
        return cc.input_file(explicit)
    path = cc.with_gz(args.directory, name)
    if required or os.path.exists(path):
        return cc.input_file(path)
    return None


def convert(args, out, bad, summary):
    from rbpf_slam import convert_msgs as m
    robot = 'Robot%d' % args.robot
    odo_path = _input(args, args.odometry, robot + '_Odometry.dat')
    meas_path = _input(args, args.measurements, robot + '_Measurement.dat')
    barcode_path = _input(args, args.barcodes, 'Barcodes.dat')
    truth_path = _input(args, args.groundtruth, robot + '_Groundtruth.dat', required=False)
    marks_path = _input(args, args.landmarks, 'Landmark_Groundtruth.dat', required=False)

    barcodes = read_barcodes(barcode_path, bad)
    t_raw, v, w = read_odometry(odo_path, bad, args.limit)
    try:
        t_odo, shared, moved = cc.spread_equal_stamps(t_raw)
    except cc.TooFewStamps as e:
        raise cc.ConversionError(odo_path, None, 'stamps that advance', got=e.got)
    span = (float(t_odo[0]), float(t_odo[-1]))
    until = float(t_raw[-1]) if args.limit else None
    x, y, th, v_step, w_step = commanded_odometry(t_odo, v, w)
    summary.note('odometry: %d commanded (v, w) lines integrated as logged (unicycle), %.1f m in %.0f s; each '
                 'message\'s twist is the command over the step ending at its stamp'
                 % (len(t_odo), float(np.sum(np.abs(np.r_[0.0, v[:-1] * np.diff(t_odo)]))), span[1] - span[0]))

    rows, lines = read_measurements(meas_path, bad, until)
    if len(rows):
        cc.check_same_clock(meas_path, int(lines[0]), rows[:, 0], span, os.path.basename(odo_path))
    inside = (rows[:, 0] >= span[0]) & (rows[:, 0] <= span[1])
    summary.skip('readings timed outside the odometry', int(np.sum(~inside)))
    readings, robot_counts, unknown_counts = landmark_readings(rows[inside], barcodes)
    summary.skip('readings of robots (subjects 1-5: not landmarks)', int(sum(robot_counts.values())))
    summary.skip('readings of barcodes Barcodes.dat does not list (misreads)', int(sum(unknown_counts.values())))
    groups = {}
    if inside.any():
        for t in np.unique(rows[inside, 0]):
            groups[float(t)] = readings[readings[:, 0] == t]
    half_fov = math.radians(args.fov)
    summary.note('landmark readings: %d at %d times (%d times without one: empty arrays); ids %s; '
                 'robots\' readings dropped: %s%s' % (
                     len(readings), len(groups), sum(1 for g in groups.values() if not len(g)),
                     '-1 (--no-ids)' if args.no_ids else 'the subjects of the barcodes read',
                     ', '.join('subject %d: %d' % kv for kv in sorted(robot_counts.items())) or 'none',
                     '; unknown barcodes: %s' % ', '.join('%d: %d' % kv for kv in sorted(unknown_counts.items()))
                     if unknown_counts else ''))
    summary.note('scope stated in every array: 0-%.1f m, +-%.0f deg; %d readings lie beyond %.1f m, %d beyond +-%.0f '
                 'deg; covariance from sigma range %.3g m, bearing %.3g rad' % (
                     args.max_range, args.fov, int(np.sum(readings[:, 2] > args.max_range)), args.max_range,
                     int(np.sum(np.abs(readings[:, 3]) > half_fov)), args.fov, args.range_sigma, args.bearing_sigma))

    truth = None
    if truth_path is not None:
        tg, gx, gy, gth = read_groundtruth(truth_path, bad, until)
        cc.check_same_clock(truth_path, None, tg, span, os.path.basename(odo_path))
        try:
            tg, g_shared, g_moved = cc.spread_equal_stamps(tg)
        except cc.TooFewStamps as e:
            raise cc.ConversionError(truth_path, None, 'stamps that advance', got=e.got)
        shared, moved = shared + g_shared, max(moved, g_moved)
        truth = [tg, gx, gy, gth]
    else:
        summary.note('no %s_Groundtruth.dat: no ground_truth/odom, ground_truth/path' % robot)
    marks = read_landmarks(marks_path, bad) if marks_path is not None else None
    if marks is None:
        summary.note('no Landmark_Groundtruth.dat: no ground_truth/landmarks')
    if shared:
        summary.note('%d odometry and truth lines share their printed stamp with others (printed with too few '
                     'digits): spread out by line number, by up to %.3f s' % (shared, moved))

    if args.truth_frame == 'start' and truth is not None:
        origin = pose_at(span[0], *truth)
        summary.note('truth in the start frame %r: the robot\'s Vicon pose at the first odometry stamp, (%.4f m, '
                     '%.4f m, %.2f deg) in the room' % (args.map_frame, origin[0], origin[1], math.degrees(origin[2])))
    else:
        origin = (0.0, 0.0, 0.0)
        summary.note('truth in the room\'s Vicon frame %r%s' % (args.map_frame, ' (no Vicon path to find the start '
                                                                                 'frame in)' if marks is not None and
                                                                 args.truth_frame == 'start' else ''))
    if truth is not None:
        truth[1], truth[2], truth[3] = to_frame(origin, truth[1], truth[2], truth[3])
    if marks is not None:
        marks[:, 1], marks[:, 2] = to_frame(origin, marks[:, 1], marks[:, 2])

    starts = [t_odo[0]] + ([min(groups)] if groups else []) + ([truth[0][0]] if truth is not None else [])
    t0 = float(min(starts))
    out.expect(2 * len(t_odo) + len(groups) + (len(truth[0]) + 1 if truth is not None else 0)
               + (marks is not None))
    scope = {'min_range': 0.0, 'max_range': args.max_range, 'fov_min': -half_fov, 'fov_max': half_fov}

    def statics():
        if marks is not None:
            trunks = [m.trunk(float(mx), float(my), covariance=(sx * sx, 0.0, 0.0, sy * sy), landmark_id=int(s))
                      for s, mx, my, sx, sy in marks]
            yield t0, args.truth_landmarks_topic, m.trunk_array(t0, args.map_frame, trunks), True

    def odometry():
        for i in range(len(t_odo)):
            t = float(t_odo[i])
            pose = float(x[i]), float(y[i]), float(th[i])
            yield t, args.odom_topic, m.odometry(t, args.odom_frame, args.base_frame, *pose, v=float(v_step[i]),
                                                 w=float(w_step[i])), False
            yield t, '/tf', m.tf_message(m.transform(t, args.odom_frame, args.base_frame, *pose)), False

    def landmarks():
        for t in sorted(groups):
            trunks = []
            for _, subject, r, b in groups[t]:
                r, b = float(r), float(b)
                trunks.append(m.trunk(r * math.cos(b), r * math.sin(b), range_=r, bearing=b,
                                      covariance=cc.polar_covariance(r, b, args.range_sigma, args.bearing_sigma),
                                      landmark_id=-1 if args.no_ids else int(subject)))
            yield t, args.landmarks_topic, m.trunk_array(t, args.base_frame, trunks, scope), False

    def reference():
        if truth is None:
            return
        tg, gx, gy, gth = truth
        for i in range(len(tg)):
            t = float(tg[i])
            yield t, args.truth_odom_topic, m.odometry(t, args.map_frame, args.truth_base_frame, float(gx[i]),
                                                       float(gy[i]), float(gth[i])), False
        t_end = float(tg[-1])
        yield t_end, args.truth_path_topic, m.path(t_end, args.map_frame, tg, gx, gy, gth), True

    out.write_merged([statics(), odometry(), landmarks(), reference()])


def main(argv=None):
    return cc.run(build_parser(), convert, argv)
