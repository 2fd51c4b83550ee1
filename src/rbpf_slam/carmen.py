"""CARMEN logs (plain or .gz) to a rosbag: odometry, laser scans and, where the log has one, a reference path.

Lines read: ``ODOM``, ``FLASER``, ``RLASER``, ``ROBOTLASER1``, ``TRUEPOS``, ``PARAM``; other types
(``NEFF``, ``SYNC``, ...) are counted and skipped.

The "corrected" logs (e.g. Intel and ACES from Radish, as shipped in ``../shared/data/carmen``) need
care, and this converter handles them:

* Both pose fields of a laser line hold the pose corrected by an offline SLAM run, and the ``ODOM``
  line right after each laser line repeats that corrected pose: it *resets* odometry to it, and the
  later ``ODOM`` lines add raw increments to it. Raw odometry is rebuilt by chaining the relative motion
  (SE(2)) between consecutive ``ODOM`` lines, and across a scan from the reset pose to the next ``ODOM``
  line; the jump from the last ``ODOM`` before the scan to the reset pose is the correction and is
  dropped. Otherwise the bag would leak the reference into the odometry. A reset line is an ``ODOM``
  line that directly follows a laser line and repeats its robot pose; its own time stamp is 0, or in
  some lines of the Intel log uninitialised garbage (1e-42, 1.13, 81.83, ...), so the stamp is not
  what identifies it. The log is taken as corrected when at least one such line has the stamp 0
  (``--corrected auto``).
* The corrected laser poses become the reference path (``ground_truth/odom``, ``ground_truth/path``
  in the frame ``map``), never the odometry. They are an offline SLAM result, not true ground truth.
  ``TRUEPOS`` lines (simulator logs) are true ground truth and take precedence.
* Some time stamps go backwards (Intel: hundreds of ``ODOM`` lines, by up to ~1 s). File order is the
  order of the motion, so the stamps of the timed lines (``ODOM``, lasers, ``TRUEPOS``) are made
  non-decreasing by the least-squares fit (isotonic regression, which moves only the stamps out of
  order); how many went backwards is reported. Odometry messages that then share a stamp keep only
  the last one (poses are cumulative, so no motion is lost; TF rejects repeated stamps anyway).
* Readings at the sensor's maximum are no returns, not walls (about 81.83-81.91 m for the SICK
  scanners, 50.0 m in ACES): they become +Inf (REP-117). By default (``--no-return auto``) the no-return
  value is the log's largest reading when at least 10 readings have it; readings above the laser's
  stated maximum range (``ROBOTLASER1``, or a ``PARAM``) are +Inf too; readings <= 0 are NaN.

Beam angles: ``ROBOTLASER1`` lines state them. ``FLASER``/``RLASER`` lines do not: the field of view
is 180 degrees from -90 degrees (``--laser-fov``) and the increment fov / n for even n, fov / (n - 1) for
odd n (1 degree for 180 or 181 beams, as GMapping's CARMEN reader has it). Laser mounting: the
``PARAM`` ``robot_frontlaser_offset`` / ``robot_frontlaser_side_offset`` /
``robot_frontlaser_angular_offset`` (and ``rearlaser``; the rear laser faces backwards by default),
or for ``ROBOTLASER1`` the laser pose relative to the robot pose of the first line; published on
``/tf_static``.

Stamps are the log's own (``timestamp`` field, seconds; relative in Radish logs, Unix in others).
"""
import collections
import math

import numpy as np

from rbpf_slam import convert_common as cc

LASER_TAGS = ('FLASER', 'RLASER', 'ROBOTLASER1')
NO_RETURN_MIN_COUNT = 10   # a reading value at least this frequent at the log's maximum is a no-return
NO_RETURN_TOLERANCE = 0.005  # [m]
POSE_EQUAL_TOLERANCE = 1e-6  # [m, rad] an ODOM line "repeats" a laser pose within this
MAX_RANGE_PARAMS = {
    'FLASER': ('laser_front_laser_max_range', 'robot_front_laser_max', 'robot_frontlaser_max'),
    'RLASER': ('laser_rear_laser_max_range', 'robot_rear_laser_max', 'robot_rearlaser_max'),
}

EXAMPLE = """
Example:
  carmen_to_bag ../shared/data/carmen/intel-corrected.log.gz -o intel.bag
  rosbag play --clock intel.bag      # /odom, /tf, /tf_static, /scan, /ground_truth/odom, /ground_truth/path
"""


class Odom(collections.namedtuple('Odom', 'line x y theta tv rv ts')):
    pass


class Laser(collections.namedtuple('Laser', 'line tag ranges angle_min angle_increment max_range '
                                             'laser_pose robot_pose ts')):
    pass


class TruePos(collections.namedtuple('TruePos', 'line pose ts')):
    pass


class Log:
    """The parsed lines of a CARMEN log, in file order."""

    def __init__(self, path):
        self.path = path
        self.params = {}
        self.records = []   # Odom, Laser, TruePos in file order
        self.other = collections.Counter()  # line types not converted

    @property
    def odom(self):
        return [r for r in self.records if isinstance(r, Odom)]

    @property
    def lasers(self):
        return [r for r in self.records if isinstance(r, Laser)]


def parse_log(path, bad=None, limit=None, laser_fov=math.pi):
    """Read a CARMEN log into a Log. ``bad``: a BadLines policy (default: stop at the first malformed
    line). ``limit``: read only the first N lines. Raises ConversionError for an empty log."""
    bad = bad or cc.BadLines()
    log = Log(path)
    n_lines = 0
    for line, tokens in cc.read_tokens(path, limit=limit):
        n_lines += 1
        tag = tokens[0]
        try:
            if tag == 'ODOM':
                cc.require_fields(tokens, 10, path, line,
                                  'ODOM x y theta tv rv accel timestamp hostname logger_timestamp')
                v = cc.parse_floats(tokens[1:8], path, line, 'numbers in the ODOM fields x y theta tv rv accel '
                                    'timestamp')
                log.records.append(Odom(line, v[0], v[1], v[2], v[3], v[4], v[6]))
            elif tag in ('FLASER', 'RLASER'):
                log.records.append(_parse_flaser(tokens, path, line, laser_fov))
            elif tag == 'ROBOTLASER1':
                log.records.append(_parse_robotlaser(tokens, path, line))
            elif tag == 'TRUEPOS':
                cc.require_fields(tokens, 10, path, line, 'TRUEPOS true_x true_y true_theta odom_x odom_y '
                                  'odom_theta timestamp hostname logger_timestamp')
                v = cc.parse_floats(tokens[1:8], path, line, 'numbers in the TRUEPOS pose and timestamp fields')
                log.records.append(TruePos(line, (v[0], v[1], v[2]), v[6]))
            elif tag == 'PARAM':
                cc.require_fields(tokens, 3, path, line, 'PARAM name value', exact=False)
                log.params[tokens[1]] = tokens[2]
            else:
                log.other[tag] += 1
        except cc.ConversionError as e:
            bad(e)
    if n_lines == 0:
        raise cc.ConversionError(path, None, 'CARMEN log lines (ODOM, FLASER, ...)', got='an empty file')
    if not log.records:
        other = ('none (%d lines of other types, e.g. %r)' % (sum(log.other.values()), next(iter(log.other)))
                 if log.other else 'none')
        raise cc.ConversionError(path, None, 'at least one ODOM, FLASER, RLASER, ROBOTLASER1 or TRUEPOS line',
                                 got=other)
    return log


def _count(tokens, index, path, line, what):
    if len(tokens) <= index:
        raise cc.ConversionError(path, line, what, got='the line ends after %d fields' % len(tokens))
    try:
        n = int(tokens[index])
    except ValueError:
        raise cc.ConversionError(path, line, what, got='%r' % tokens[index])
    if n < 0:
        raise cc.ConversionError(path, line, what, got=n)
    return n


def _parse_flaser(tokens, path, line, fov):
    tag = tokens[0]
    n = _count(tokens, 1, path, line, 'the number of readings after %s' % tag)
    cc.require_fields(tokens, 2 + n + 9, path, line, '%s n, %d readings, x y theta odom_x odom_y odom_theta '
                      'timestamp hostname logger_timestamp' % (tag, n))
    ranges = cc.parse_floats(tokens[2:2 + n], path, line, 'numbers as %s readings' % tag)
    v = cc.parse_floats(tokens[2 + n:2 + n + 7], path, line, 'numbers in the %s pose and timestamp fields' % tag)
    increment = fov / (n - n % 2) if n > 1 else 0.0
    return Laser(line, tag, ranges, -fov / 2.0, increment, None, (v[0], v[1], v[2]), (v[3], v[4], v[5]), v[6])


def _parse_robotlaser(tokens, path, line):
    n = _count(tokens, 8, path, line, 'the number of readings (field 8) of ROBOTLASER1')
    n_rem = _count(tokens, 9 + n, path, line, 'the number of remission values after the %d readings' % n)
    cc.require_fields(tokens, 9 + n + 1 + n_rem + 14, path, line,
                      'ROBOTLASER1 type start_angle fov resolution max_range accuracy remission_mode n, %d readings, '
                      'n_remissions, %d remissions, laser x y theta, robot x y theta, tv rv forward_safety '
                      'side_safety turn_axis timestamp hostname logger_timestamp' % (n, n_rem))
    head = cc.parse_floats(tokens[2:6], path, line, 'numbers as ROBOTLASER1 start_angle fov resolution max_range')
    ranges = cc.parse_floats(tokens[9:9 + n], path, line, 'numbers as ROBOTLASER1 readings')
    k = 9 + n + 1 + n_rem
    v = cc.parse_floats(tokens[k:k + 12], path, line, 'numbers in the ROBOTLASER1 pose, velocity and timestamp '
                        'fields')
    return Laser(line, 'ROBOTLASER1', ranges, head[0], head[2], head[3], (v[0], v[1], v[2]), (v[3], v[4], v[5]),
                 v[11])


def _same_pose(a, b):
    return (abs(a[0] - b[0]) <= POSE_EQUAL_TOLERANCE and abs(a[1] - b[1]) <= POSE_EQUAL_TOLERANCE
            and abs(float(cc.wrap_angle(a[2] - b[2]))) <= POSE_EQUAL_TOLERANCE)


def find_resets(records):
    """Indices (into ``records``) of ODOM lines that directly follow a laser line and repeat its robot
    pose: the resets of a corrected log. Returns (indices, how many of them have the stamp 0)."""
    resets, zero = [], 0
    for i in range(1, len(records)):
        r, prev = records[i], records[i - 1]
        if isinstance(r, Odom) and isinstance(prev, Laser) and _same_pose((r.x, r.y, r.theta), prev.robot_pose):
            resets.append(i)
            zero += r.ts == 0.0
    return resets, zero


def rebuild_raw_odometry(poses, is_reset):
    """Raw odometry from logged ODOM poses of which some are resets to a corrected pose.

    Chains the SE(2) motion between consecutive logged poses (a reset pose stands in for the pose just
    before the next line), so the correction (last pose before a reset -> reset pose) never enters.
    Starts at the first non-reset pose as logged. Returns a list of (x, y, theta), one per non-reset pose.
    """
    out = []
    raw = None
    prev = None
    for pose, reset in zip(poses, is_reset):
        if reset:
            prev = pose
            continue
        if raw is None:
            raw = tuple(pose)
        else:
            raw = cc.se2_compose(raw, cc.se2_between(prev, pose))
        prev = pose
        out.append(raw)
    return out


def rep117_ranges(ranges, no_return, range_max):
    """Readings in REP-117 form: >= the no-return value (within 5 mm) or > range_max -> +Inf, <= 0 -> NaN."""
    r = np.array(ranges, dtype=float)
    inf = r > range_max
    if no_return is not None:
        inf |= r >= no_return - NO_RETURN_TOLERANCE
    r[inf] = np.inf
    r[r <= 0.0] = np.nan
    return r


def detect_no_return(lasers, min_count=NO_RETURN_MIN_COUNT):
    """The no-return value: the largest reading of the log if at least ``min_count`` readings have it."""
    if not lasers:
        return None, 0
    all_ranges = np.concatenate([l.ranges for l in lasers])
    if all_ranges.size == 0:
        return None, 0
    top = float(all_ranges.max())
    n = int(np.sum(all_ranges >= top - NO_RETURN_TOLERANCE))
    return (top, n) if n >= min_count else (None, 0)


def _param_float(params, names, default=None):
    for name in names:
        if name in params:
            try:
                return float(params[name])
            except ValueError:
                pass
    return default


def laser_mounts(log):
    """Static pose (x, y, yaw) of each laser type in the robot frame."""
    mounts = {}
    p = log.params
    for tag in set(l.tag for l in log.lasers):
        if tag == 'FLASER':
            mounts[tag] = (_param_float(p, ('robot_frontlaser_offset',), 0.0),
                           _param_float(p, ('robot_frontlaser_side_offset',), 0.0),
                           _param_float(p, ('robot_frontlaser_angular_offset',), 0.0))
        elif tag == 'RLASER':
            mounts[tag] = (_param_float(p, ('robot_rearlaser_offset',), 0.0),
                           _param_float(p, ('robot_rearlaser_side_offset',), 0.0),
                           _param_float(p, ('robot_rearlaser_angular_offset',), math.pi))
        else:
            first = next(l for l in log.lasers if l.tag == tag)
            mounts[tag] = cc.se2_between(first.robot_pose, first.laser_pose)
    return mounts


class Conversion:
    """Everything the bag will hold, computed from a Log (pure numpy: the tests check it directly)."""

    def __init__(self, log, corrected='auto', laser_poses='auto', no_return='auto'):
        self.log = log
        self.notes = []
        self.skipped = collections.Counter()
        records = log.records
        resets, zero_resets = find_resets(records)
        if corrected == 'auto':
            self.corrected = zero_resets > 0
        else:
            self.corrected = corrected == 'yes'
        reset_set = set(resets) if self.corrected else set()
        if self.corrected:
            self.notes.append('corrected log: %d ODOM lines repeat the corrected pose of the laser line before them '
                              '(reset; %d of them with a time stamp other than 0); raw odometry rebuilt by chaining '
                              'the relative motion between ODOM lines' % (len(reset_set), len(reset_set) - zero_resets))
            self.skipped['ODOM lines that reset odometry to the corrected pose (not odometry)'] = len(reset_set)
        self.n_resets = len(reset_set)
        self.n_garbage_reset_stamps = len(reset_set) - zero_resets if self.corrected else 0

        # Timed records in file order (resets carry no usable stamp).
        timed = [i for i, r in enumerate(records) if i not in reset_set]
        if timed:
            stamps, backward, self.n_invalid_stamps = cc.fix_stamps([records[i].ts for i in timed])
        else:
            stamps, backward, self.n_invalid_stamps = np.zeros(0), (0, 0, 0.0), 0
        self.n_backward, self.n_out_of_order, self.max_backward = backward
        fixed = dict(zip(timed, stamps))
        kinds = [type(records[i]) for i in timed]
        self.n_backward_odom = cc.count_backward([records[i].ts for i, k in zip(timed, kinds) if k is Odom])[0]
        self.n_backward_laser = cc.count_backward([records[i].ts for i, k in zip(timed, kinds) if k is Laser])[0]
        if self.n_backward:
            self.notes.append('time stamps going backwards: %d lines have a stamp earlier than the line before '
                              '(%d ODOM after ODOM, %d laser after laser); %d lines in all are earlier than some '
                              'line before them, by up to %.3f s; made non-decreasing by a least-squares (isotonic) '
                              'fit'
                              % (self.n_backward, self.n_backward_odom, self.n_backward_laser, self.n_out_of_order,
                                 self.max_backward))
        if self.n_invalid_stamps:
            self.notes.append('%d time stamps more than %.0f s before the previous ones (or <= 0) took the previous '
                              'stamp' % (self.n_invalid_stamps, cc.MAX_BACKWARD_STEP))

        # Raw odometry.
        odom_idx = [i for i, r in enumerate(records) if isinstance(r, Odom)]
        poses = [(records[i].x, records[i].y, records[i].theta) for i in odom_idx]
        raw = rebuild_raw_odometry(poses, [i in reset_set for i in odom_idx])
        kept = [i for i in odom_idx if i not in reset_set]
        self.raw_odom_all = np.array(raw).reshape(-1, 3)
        self.odom_stamps_all = np.array([fixed[i] for i in kept])
        twist = np.array([(records[i].tv, records[i].rv) for i in kept]).reshape(-1, 2)

        self.lasers = [records[i] for i in timed if isinstance(records[i], Laser)]
        self.laser_stamps = np.array([fixed[i] for i in timed if isinstance(records[i], Laser)])
        truepos = [records[i] for i in timed if isinstance(records[i], TruePos)]
        truepos_stamps = np.array([fixed[i] for i in timed if isinstance(records[i], TruePos)])

        # Which poses are odometry and which are the reference.
        self.reference_source = None
        if laser_poses == 'auto':
            laser_poses = 'reference' if (self.corrected or not odom_idx) else 'ignore'
        if laser_poses == 'odometry' and self.lasers:
            self.raw_odom_all = np.array([l.robot_pose for l in self.lasers]).reshape(-1, 3)
            self.odom_stamps_all = self.laser_stamps.copy()
            twist = np.zeros((len(self.lasers), 2))
            self.notes.append('odometry from the robot poses of the laser lines (--laser-poses odometry): in a '
                              'corrected log that is the reference, not odometry')
            if odom_idx:
                self.skipped['ODOM lines (odometry taken from the laser lines instead)'] += len(kept)
        if truepos:
            self.reference_source = 'TRUEPOS lines (true poses)'
            self.reference = np.array([t.pose for t in truepos]).reshape(-1, 3)
            self.reference_stamps = truepos_stamps
        elif laser_poses == 'reference' and self.lasers:
            self.reference_source = ('the corrected robot poses of the laser lines (an offline SLAM result, not '
                                     'true ground truth)' if self.corrected else 'the robot poses of the laser lines')
            self.reference = np.array([l.robot_pose for l in self.lasers]).reshape(-1, 3)
            self.reference_stamps = self.laser_stamps.copy()
        else:
            self.reference = np.zeros((0, 3))
            self.reference_stamps = np.zeros(0)
        if not odom_idx and laser_poses != 'odometry':
            self.notes.append('the log has no ODOM lines: no odometry written (if its laser poses are raw odometry, '
                              'use --laser-poses odometry)')

        keep = cc.last_of_equal_runs(self.odom_stamps_all)
        self.skipped['odometry poses sharing a stamp with the next one (merged: the later, cumulative pose is '
                     'kept)'] = len(self.odom_stamps_all) - len(keep)
        self.odom = self.raw_odom_all[keep]
        self.odom_stamps = self.odom_stamps_all[keep]
        self.odom_twist = twist[keep]

        # Ranges.
        if no_return == 'auto':
            self.no_return, n_no_return = detect_no_return(self.lasers)
        else:
            self.no_return = float(no_return) if no_return not in (None, 'none') else None
            n_no_return = 0
        self.range_max = {}
        for tag in set(l.tag for l in self.lasers):
            stated = [l.max_range for l in self.lasers if l.tag == tag and l.max_range]
            param = _param_float(log.params, MAX_RANGE_PARAMS.get(tag, ()))
            if stated:
                self.range_max[tag] = float(min(stated))
            elif param is not None:
                self.range_max[tag] = param
            elif self.no_return is not None:
                self.range_max[tag] = self.no_return - NO_RETURN_TOLERANCE
            else:
                self.range_max[tag] = float(max(l.ranges.max() for l in self.lasers if l.tag == tag and len(l.ranges)))
        n_inf = sum(int(np.sum(np.isinf(rep117_ranges(l.ranges, self.no_return, self.range_max[l.tag]))))
                    for l in self.lasers)
        if self.lasers:
            what = ('no-return value %.3f m (%d readings)' % (self.no_return, n_no_return)
                    if self.no_return is not None else 'no no-return value found')
            self.notes.append('%s; %d readings written as +Inf (REP-117); range_max %s' % (
                what, n_inf, ', '.join('%s %.2f m' % kv for kv in sorted(self.range_max.items()))))
        self.mounts = laser_mounts(log)
        for tag, n in sorted(log.other.items()):
            self.skipped['%s lines (not converted)' % tag] = n


def build_parser():
    p = cc.make_parser('carmen_to_bag', __doc__)
    p.add_argument('log', help='CARMEN log, plain or gzip-compressed')
    p.add_argument('--corrected', choices=('auto', 'yes', 'no'), default='auto',
                   help='whether ODOM lines after laser lines reset odometry to a corrected pose (default auto)')
    p.add_argument('--laser-poses', choices=('auto', 'reference', 'odometry', 'ignore'), default='auto',
                   help='what the robot poses of the laser lines are: auto = the reference path in a corrected log '
                        'or a log without ODOM lines, else ignored')
    p.add_argument('--no-return', default='auto', metavar='M',
                   help='reading [m] that means no return (-> +Inf); auto = the log\'s largest reading if at least '
                        '%d readings have it; none = no such value' % NO_RETURN_MIN_COUNT)
    p.add_argument('--laser-fov', type=float, default=180.0, metavar='DEG',
                   help='field of view of FLASER/RLASER lines, centred on the laser\'s axis (default 180)')
    cc.add_common_arguments(
        p,
        topics=(('--odom-topic', 'odom', 'nav_msgs/Odometry, raw odometry'),
                ('--scan-topic', 'scan', 'sensor_msgs/LaserScan of FLASER and ROBOTLASER1 lines'),
                ('--rear-scan-topic', 'scan_rear', 'sensor_msgs/LaserScan of RLASER lines'),
                ('--truth-odom-topic', 'ground_truth/odom', 'nav_msgs/Odometry, the reference poses'),
                ('--truth-path-topic', 'ground_truth/path', 'nav_msgs/Path, the whole reference path (once, at its '
                 'end)')),
        frames=(('--odom-frame', 'odom', 'odometry frame'),
                ('--base-frame', 'base_link', 'robot frame'),
                ('--laser-frame', 'laser', 'front laser frame'),
                ('--rear-laser-frame', 'laser_rear', 'rear laser frame'),
                ('--map-frame', 'map', 'frame of the reference path'),
                ('--truth-base-frame', 'base_link_truth', 'child frame of the reference poses')))
    p.epilog = 'A record for --limit is a line of the log.' + '\n' + EXAMPLE
    return p


def convert(args, out, bad, summary):
    from rbpf_slam import convert_msgs as m
    log = parse_log(args.log, bad, limit=args.limit, laser_fov=math.radians(args.laser_fov))
    conv = Conversion(log, corrected=args.corrected, laser_poses=args.laser_poses, no_return=args.no_return)
    for reason, n in conv.skipped.items():
        summary.skip(reason, n)
    for note in conv.notes:
        summary.note(note)
    if conv.reference_source:
        summary.note('reference path: %s' % conv.reference_source)

    stamps = [s for s in (conv.odom_stamps[:1], conv.laser_stamps[:1], conv.reference_stamps[:1]) if len(s)]
    t0 = min(float(s[0]) for s in stamps)
    frame_of = {'FLASER': args.laser_frame, 'ROBOTLASER1': args.laser_frame, 'RLASER': args.rear_laser_frame}
    topic_of = {'FLASER': args.scan_topic, 'ROBOTLASER1': args.scan_topic, 'RLASER': args.rear_scan_topic}
    n_ref = len(conv.reference_stamps)
    out.expect(2 * len(conv.odom_stamps) + len(conv.lasers) + n_ref + (1 if n_ref else 0) + (1 if conv.mounts else 0))

    def statics():
        if conv.mounts:
            tfs = [m.transform(t0, args.base_frame, frame_of[tag], x, y, yaw)
                   for tag, (x, y, yaw) in sorted(conv.mounts.items())]
            yield t0, '/tf_static', m.tf_message(*tfs), True

    def odometry():
        for (x, y, th), t, (tv, rv) in zip(conv.odom, conv.odom_stamps, conv.odom_twist):
            t = float(t)
            yield t, args.odom_topic, m.odometry(t, args.odom_frame, args.base_frame, x, y, th, tv, rv), False
            yield t, '/tf', m.tf_message(m.transform(t, args.odom_frame, args.base_frame, x, y, th)), False

    def scans():
        for laser, t in zip(conv.lasers, conv.laser_stamps):
            ranges = rep117_ranges(laser.ranges, conv.no_return, conv.range_max[laser.tag])
            t = float(t)
            yield t, topic_of[laser.tag], m.laser_scan(t, frame_of[laser.tag], laser.angle_min, laser.angle_increment,
                                                       ranges.tolist(), 0.0, conv.range_max[laser.tag]), False

    def reference():
        for (x, y, th), t in zip(conv.reference, conv.reference_stamps):
            t = float(t)
            yield t, args.truth_odom_topic, m.odometry(t, args.map_frame, args.truth_base_frame, x, y, th), False
        if n_ref:
            t_end = float(conv.reference_stamps[-1])
            yield t_end, args.truth_path_topic, m.path(t_end, args.map_frame, conv.reference_stamps,
                                                       conv.reference[:, 0], conv.reference[:, 1],
                                                       conv.reference[:, 2]), True

    out.write_merged([statics(), odometry(), scans(), reference()])


def main(argv=None):
    return cc.run(build_parser(), convert, argv)
