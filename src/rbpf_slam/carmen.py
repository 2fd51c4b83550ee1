"""CARMEN logs (plain or .gz) to a rosbag: odometry, laser scans and, where the log has one, a reference path.

Lines read: ``ODOM``, ``FLASER``, ``RLASER``, ``ROBOTLASER1``, ``TRUEPOS``, ``PARAM``; other types
(``NEFF``, ``SYNC``, ...) are counted and skipped. The timed lines are the ``ODOM``, laser and ``TRUEPOS``
lines (not the resets below).

Odometry is the raw odometry of the ``ODOM`` lines, and a scan gets the pose of the ``ODOM`` line before
it in the file, as the log itself pairs them: the bag holds an odometry sample at each scan's stamp with
that pose, so odometry read at a scan's stamp (``/odom`` or TF, interpolated there) is exactly it. A log
without ``ODOM`` lines is refused (exit 1, no bag) unless told what to do: ``--laser-poses odometry`` when
the poses of its laser lines are raw odometry, ``--no-odometry`` to write the scans and the reference only.
So is a log whose ``ODOM`` lines repeat the robot poses of the laser lines next to them (before or after, within
1 mm and 1e-4 rad, for at least 90 % of the ``ODOM`` lines next to a laser line while the robot moves; resets
aside): its ``ODOM`` lines may be corrected poses as well as raw odometry that the laser lines copy, and the log
cannot tell which. ``--corrected no`` takes them as raw odometry; ``--laser-poses odometry`` and
``--no-odometry`` as above.

The "corrected" logs (e.g. Intel and ACES from Radish) need care, and this converter handles them:

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

Time stamps are the log's own (``timestamp`` field, seconds; relative in Radish logs, Unix in others),
except garbage ones, which are rebuilt from the line order. A stamp is garbage when it is not a positive
number below 2^32 s (ROS time holds the seconds as uint32; e.g. the text 4.29497e+09 some logs carry), when
it repeats one value over a run of lines that would last more than 10 s at the log's seconds per line (a
stuck clock; all but the first of the run), when it is more than 5 s (and more than 10 lines' time) away
from the median of the 21 lines around it, when it lies on a stretch of lines that jumps away from the
rest of the log (more than 5 s back, or more than an hour and 1000 lines' time forward, the stretches
telling one story over the most lines being kept), or when it is more than 5 s earlier than an earlier line's.
Garbage stamps are interpolated by line number between the trustworthy stamps around them; before the first
and after the last trustworthy stamp they go on at the seconds per line measured on the trustworthy stamps,
or given by ``--line-period S``. ``--stamps lines`` rebuilds every stamp, evenly spaced from the first
trustworthy one. The summary says how many stamps were rebuilt, why, from which line on, and at what
seconds per line. A log whose stamps do not advance (all equal, all 0) is refused unless ``--line-period``
is given.

Stamps going back by less than that (Intel: hundreds of ``ODOM`` lines, by up to ~1 s) are made
non-decreasing by the least-squares fit (isotonic regression, which moves only the stamps out of order);
how many went backwards is reported. Then lines that share a stamp (logged at once, or pooled by the fit)
are moved 1 microsecond apart, so the stamps follow the file order strictly and no odometry sample is
dropped.

Odometry gaps: consecutive ``ODOM`` lines more than ``--odom-gap`` seconds apart (default 1) while the robot
moves (the reference moves more than 0.1 m or turns more than 10 degrees, the odometry jumps as much, or the
scans in between change) are reported with their lines, duration and motion: odometry interpolated inside
such a gap does not follow the robot.

Readings at the sensor's maximum are no returns, not walls (about 81.83-81.91 m for the SICK scanners, 50.0 m
in ACES, about 51.1 m in fhw and MIT's infinite corridor): they become +Inf (REP-117). By default
(``--no-return auto``) they are the top cluster of the log's readings: readings within 0.2 m of its lower edge,
at least 10 of them, at least 10 times as many as in the 0.2 m below the edge (a gap: the far walls of a long
corridor, spread out in range, are no cluster), and above the 0.2 m only a few strays (at most 1 % of the
cluster). Whatever steps the log writes its ranges in (1 cm, 5 cm), no step between the readings is assumed.
Readings from 5 mm below the cluster's lower edge up are +Inf;
the summary gives the cluster (from-to m, readings). Readings above the laser's stated maximum range
(``ROBOTLASER1``'s max_range, or a ``PARAM`` such as ``robot_front_laser_max``) are +Inf too, and the summary
says how many such a cap made +Inf; ``--laser-max M`` overrides the log's cap (``none``: no cap). Readings
<= 0 are NaN.

Beam angles: ``ROBOTLASER1`` lines state them. ``FLASER``/``RLASER`` lines do not: the field of view
is 180 degrees from -90 degrees (``--laser-fov``) and the increment fov / n for even n, fov / (n - 1) for
odd n (1 degree for 180 or 181 beams, as GMapping's CARMEN reader has it). Laser mounting: the
``PARAM`` ``robot_frontlaser_offset`` / ``robot_frontlaser_side_offset`` /
``robot_frontlaser_angular_offset`` (and ``rearlaser``; the rear laser faces backwards by default),
or for ``ROBOTLASER1`` the laser pose relative to the robot pose of the first line; published on
``/tf_static``.
"""
import argparse
import collections
import math

import numpy as np

from rbpf_slam import convert_common as cc

LASER_TAGS = ('FLASER', 'RLASER', 'ROBOTLASER1')
# The no-return readings are the top cluster of the log's readings (detect_no_return): within NO_RETURN_BAND of
# its lower edge, at most NO_RETURN_STRAYS of its count above that band, at least NO_RETURN_MIN_COUNT readings,
# and at least NO_RETURN_CONTRAST times as many as in the NO_RETURN_BAND below the edge (a gap below it: the far
# walls of a long corridor, spread out in range, are no cluster).
NO_RETURN_MIN_COUNT = 10
NO_RETURN_BAND = 0.2        # [m]
NO_RETURN_STRAYS = 0.01     # a share of the cluster's readings
NO_RETURN_CONTRAST = 10
NO_RETURN_TOLERANCE = 0.005  # [m] readings this far below the cluster's lower edge are no-returns too
POSE_EQUAL_TOLERANCE = 1e-6  # [m, rad] a reset ODOM line repeats the laser pose before it within this
# An ODOM line that repeats the pose of a laser line next to it (within these; the two may be written with
# different digits) is no raw odometry when most such lines of a log do: at least REPEAT_SHARE of at least
# REPEAT_MIN_PAIRS ODOM lines next to a laser line while the robot moves.
REPEAT_TOLERANCE = (1e-3, 1e-4)  # [m, rad]
REPEAT_SHARE = 0.9
REPEAT_MIN_PAIRS = 5
MAX_RANGE_PARAMS = {
    'FLASER': ('laser_front_laser_max_range', 'robot_front_laser_max', 'robot_frontlaser_max'),
    'RLASER': ('laser_rear_laser_max_range', 'robot_rear_laser_max', 'robot_rearlaser_max'),
}

EXAMPLE = """
Example:
  carmen_to_bag intel-corrected.log.gz -o intel.bag
  rosbag play --clock intel.bag      # /odom, /tf, /tf_static, /scan, /ground_truth/odom, /ground_truth/path
  carmen_to_bag csail.log -o csail.bag --no-odometry     # laser lines with corrected poses, no ODOM lines
  carmen_to_bag orebro.log -o orebro.bag --laser-poses odometry --line-period 0.1   # raw poses, stamps all 0
  carmen_to_bag robot.log -o robot.bag --laser-max none   # keep the readings a PARAM ..._laser_max would cap
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
        raise cc.ConversionError(path, line, what, got=cc.quote(tokens[index]))
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


def _repeats(a, b):
    return (abs(a[0] - b[0]) <= REPEAT_TOLERANCE[0] and abs(a[1] - b[1]) <= REPEAT_TOLERANCE[0]
            and abs(float(cc.wrap_angle(a[2] - b[2]))) <= REPEAT_TOLERANCE[1])


def find_repeats(records, resets=()):
    """ODOM lines that repeat the robot pose of a laser line next to them (the record before or after), the
    resets (indices into ``records``) aside. Counted are the ODOM lines next to a laser line whose pose differs
    from the ODOM line before them (the robot moves; a robot standing still repeats every pose). Returns
    (repeats, pairs): a log whose ODOM lines are raw odometry has few repeats (a laser line's pose is odometry
    at another time, or a corrected pose); one whose ODOM lines are the laser poses has nearly all."""
    resets = set(resets)
    pairs = repeats = 0
    prev = None
    for i, r in enumerate(records):
        if not isinstance(r, Odom):
            continue
        pose = (r.x, r.y, r.theta)
        before = prev
        prev = pose
        if i in resets or before is None or _repeats(pose, before):
            continue
        lasers = [records[j] for j in (i - 1, i + 1) if 0 <= j < len(records) and isinstance(records[j], Laser)]
        if lasers:
            pairs += 1
            repeats += any(_repeats(pose, l.robot_pose) for l in lasers)
    return repeats, pairs


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


class NoReturn(collections.namedtuple('NoReturn', 'low high count below')):
    """The top cluster of a log's readings: its lower and upper edge [m], its readings, and the readings in
    the NO_RETURN_BAND below it."""


def detect_no_return(lasers, min_count=NO_RETURN_MIN_COUNT):
    """The no-return readings of a log: its top cluster of readings (see NO_RETURN_*) as a NoReturn, or None
    when the top of the ranges is no such cluster. Its ``low`` is the no-return value.

    Each reading from the largest down is a candidate lower edge: the readings from it up to NO_RETURN_BAND above
    it are the cluster, those further up its strays. A candidate holds when the strays are at most
    NO_RETURN_STRAYS of the cluster's count, the cluster and its strays count min_count readings, and the cluster
    NO_RETURN_CONTRAST times the readings in the NO_RETURN_BAND below it. Of the candidates that hold one after
    the other, the one with the fewest readings below it (the highest of equals) is the edge. No step between
    readings is assumed: a log's ranges may be written in steps of 1 cm or of 5 cm."""
    ranges = [l.ranges for l in lasers if len(l.ranges)]
    if not ranges:
        return None
    r = np.concatenate(ranges)
    values, counts = np.unique(r[np.isfinite(r) & (r > 0.0)], return_counts=True)
    if not len(values):
        return None
    eps = 1e-9
    cumulative = np.concatenate([[0], np.cumsum(counts)])  # readings below values[k]: cumulative[k]

    def readings_below(x):
        """Readings < x."""
        return int(cumulative[np.searchsorted(values, x - eps, side='left')])

    def readings_up_to(x):
        """Readings <= x."""
        return int(cumulative[np.searchsorted(values, x + eps, side='right')])

    total = int(cumulative[-1])
    best = None
    for k in range(len(values) - 1, -1, -1):
        low = float(values[k])
        top = low + NO_RETURN_BAND
        n = readings_up_to(top) - readings_below(low)
        strays = total - readings_up_to(top)
        if strays > NO_RETURN_STRAYS * total:
            break  # no lower edge can hold
        below = readings_below(low) - readings_below(low - NO_RETURN_BAND)
        if strays <= NO_RETURN_STRAYS * n and n + strays >= min_count and n >= NO_RETURN_CONTRAST * below:
            if best is None or below < best.below:
                best = NoReturn(low, float(values[-1]), n + strays, below)
        elif best is not None:
            break
    return best


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


GAP_MOVE = 0.1              # [m] motion during an odometry gap worth reporting ...
GAP_TURN = math.radians(10)  # [rad] ... or turn
GAP_SCAN_CHANGE = 0.1       # [m] median change of the ranges of the scans in a gap worth reporting
GAPS_LISTED = 10            # gaps listed one by one in the summary (the longest)

NEEDS_ODOMETRY = ('raw odometry: ODOM lines (--laser-poses odometry if the laser lines\' poses are raw '
                  'odometry; --no-odometry to write none)')
NEEDS_RAW_ODOMETRY = ('raw odometry: ODOM lines that do not repeat the poses of the laser lines next to them (within '
                      '%g m and %g rad, while the robot moves; --corrected no if they are raw odometry all the same, '
                      'the laser lines copying their poses; --laser-poses odometry to take the laser lines\' poses as '
                      'odometry, knowingly; --no-odometry to write none)' % REPEAT_TOLERANCE)
NEEDS_STAMPS = 'time stamps that advance (--line-period S: the seconds from one line to the next)'


class Conversion:
    """Everything the bag will hold, computed from a Log (pure numpy: the tests check it directly).

    Raises ConversionError for a log without raw odometry: without ODOM lines, or whose ODOM lines repeat the
    laser lines' poses (find_repeats; unless ``corrected`` is 'no'), unless ``laser_poses`` is 'odometry' or
    ``no_odometry``; and for a log whose stamps do not advance (unless ``line_period``).

    ``laser_max`` [m]: readings beyond it are +Inf, instead of beyond the log's cap (a ROBOTLASER1 line's
    max_range, or a PARAM of MAX_RANGE_PARAMS); 0 or inf: no cap; None: the log's cap."""

    def __init__(self, log, corrected='auto', laser_poses='auto', no_return='auto', line_period=None, stamps='log',
                 no_odometry=False, odom_gap=1.0, time_offset=0.0, laser_max=None):
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
        odom_idx = [i for i, r in enumerate(records) if isinstance(r, Odom)]
        kept = [i for i in odom_idx if i not in reset_set]
        self.lasers = [r for r in records if isinstance(r, Laser)]
        # ODOM lines that only repeat the laser poses: no raw odometry, though the log cannot tell whether
        # they are corrected poses or the laser lines copy raw odometry. Refused unless told.
        self.n_repeats, self.n_repeat_pairs = find_repeats(records, reset_set) if corrected != 'no' else (0, 0)
        repeated = (self.n_repeat_pairs >= REPEAT_MIN_PAIRS
                    and self.n_repeats >= REPEAT_SHARE * self.n_repeat_pairs)
        if laser_poses == 'auto':
            laser_poses = 'reference' if (self.corrected or not kept or (repeated and no_odometry)) else 'ignore'
        self.odometry_source = ('laser' if laser_poses == 'odometry' and self.lasers else
                                'none' if no_odometry or not kept else 'odom')

        # What the log lacks: raw odometry, stamps that advance. Both are said at once.
        problems = []
        if not kept and laser_poses != 'odometry' and not no_odometry:
            lines = collections.Counter(type(r).__name__ if not isinstance(r, Laser) else r.tag for r in records)
            problems.append((NEEDS_ODOMETRY, 'no ODOM line (%s)' % ', '.join(
                '%d %s' % (n, 'TRUEPOS' if tag == 'TruePos' else 'ODOM resets' if tag == 'Odom' else tag)
                for tag, n in sorted(lines.items()))))
        elif repeated and laser_poses != 'odometry' and not no_odometry:
            problems.append((NEEDS_RAW_ODOMETRY, 'ODOM lines that repeat the laser poses (%d of %d next to a laser '
                             'line)' % (self.n_repeats, self.n_repeat_pairs)))
        # Timed records in file order (resets carry no usable stamp).
        timed = [i for i, r in enumerate(records) if i not in reset_set]
        try:
            self.stamp_repair = cc.repair_stamps([records[i].ts for i in timed], line_period=line_period,
                                                 rebuild_all=stamps == 'lines')
        except cc.TooFewStamps as e:
            problems.append((NEEDS_STAMPS, e.got))
        if problems:
            raise cc.ConversionError(log.path, None, ' and '.join(p[0] for p in problems),
                                     got='; '.join(p[1] for p in problems))
        repair = self.stamp_repair
        self.n_backward, self.n_out_of_order, self.max_backward = repair.backward
        self.n_invalid_stamps = len(repair.rebuilt)
        fixed_stamps, self.n_nudged, self.max_nudge = cc.strictly_increasing(repair.stamps)
        self._check_range(fixed_stamps, [records[i] for i in timed], time_offset)
        fixed = dict(zip(timed, fixed_stamps))
        self._stamp_notes(repair, [records[i] for i in timed], stamps == 'lines')
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
        if self.n_nudged:
            self.notes.append('%d timed lines had the stamp of the line before them (logged at once, or pooled by the '
                              'fit): each moved %.0f us after the line before it (at most %.0f us), so that the stamps '
                              'follow the file order' % (self.n_nudged, cc.STAMP_NUDGE * 1e6, self.max_nudge * 1e6))

        # Raw odometry of the ODOM lines, and the pose of the ODOM line before each scan.
        poses = [(records[i].x, records[i].y, records[i].theta) for i in odom_idx]
        raw = rebuild_raw_odometry(poses, [i in reset_set for i in odom_idx])
        self.raw_odom_all = np.array(raw).reshape(-1, 3)
        self.odom_stamps_all = np.array([fixed[i] for i in kept])
        self.odom_lines_all = np.array([records[i].line for i in kept], dtype=int)
        twist = np.array([(records[i].tv, records[i].rv) for i in kept]).reshape(-1, 2)
        position = {i: k for k, i in enumerate(kept)}
        held, last, n_before_odom = [], None, 0   # (scan stamp, index of the ODOM line before it)
        for i, r in enumerate(records):
            if i in position:
                last = position[i]
            elif isinstance(r, Laser):
                if last is None:
                    n_before_odom += 1
                else:
                    held.append((fixed[i], last))

        self.laser_stamps = np.array([fixed[i] for i in timed if isinstance(records[i], Laser)])
        truepos = [records[i] for i in timed if isinstance(records[i], TruePos)]
        truepos_stamps = np.array([fixed[i] for i in timed if isinstance(records[i], TruePos)])

        # Which poses are odometry and which are the reference.
        self.reference_source = None
        self.n_held = 0
        if self.odometry_source == 'laser':
            self.odom = np.array([l.robot_pose for l in self.lasers]).reshape(-1, 3)
            self.odom_stamps = self.laser_stamps.copy()
            self.odom_twist = np.zeros((len(self.lasers), 2))
            self.notes.append('odometry from the robot poses of the laser lines (--laser-poses odometry): in a '
                              'corrected log that is the reference, not odometry')
            if kept:
                self.skipped['ODOM lines (odometry taken from the laser lines instead)'] += len(kept)
        elif self.odometry_source == 'odom':
            k = np.array([h[1] for h in held], dtype=int)
            stamps_all = np.concatenate([self.odom_stamps_all, [h[0] for h in held]])
            order = np.argsort(stamps_all, kind='stable')
            self.odom = np.concatenate([self.raw_odom_all, self.raw_odom_all[k]])[order]
            self.odom_stamps = stamps_all[order]
            self.odom_twist = np.concatenate([twist, twist[k]])[order]
            self.n_held = len(held)
            if held:
                self.notes.append('%d odometry samples added at the stamps of the scans, each holding the raw pose of '
                                  'the ODOM line before the scan (the log pairs them so): odometry read at a scan\'s '
                                  'stamp is that pose' % len(held))
            if n_before_odom:
                self.notes.append('%d scans come before the first ODOM line: no odometry before them' % n_before_odom)
        else:
            self.odom, self.odom_stamps, self.odom_twist = np.zeros((0, 3)), np.zeros(0), np.zeros((0, 2))
            if kept:
                self.skipped['ODOM lines (--no-odometry)'] += len(kept)
            self.notes.append('no odometry written (%s)' % ('--no-odometry' if no_odometry else 'the log has none'))
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

        # Ranges.
        self._ranges(log, no_return, laser_max)

        self.odom_gaps, self.n_quiet_gaps = [], 0
        if self.odometry_source == 'odom':
            self.odom_gaps, self.n_quiet_gaps = self._find_gaps(odom_gap)
            self._gap_notes(odom_gap)
        self.mounts = laser_mounts(log)
        for tag, n in sorted(log.other.items()):
            self.skipped['%s lines (not converted)' % tag] = n

    def _ranges(self, log, no_return, laser_max):
        """The no-return value and each laser's cap (range_max), and their notes."""
        self.no_return_cluster = None
        if no_return == 'auto':
            self.no_return_cluster = detect_no_return(self.lasers)
            self.no_return = self.no_return_cluster.low if self.no_return_cluster else None
        else:
            self.no_return = float(no_return) if no_return not in (None, 'none') else None
        if laser_max is not None and (laser_max <= 0.0 or math.isinf(laser_max)):
            laser_max = math.inf   # no cap
        self.range_max, self.capped = {}, {}
        for tag in sorted(set(l.tag for l in self.lasers)):
            tagged = [l for l in self.lasers if l.tag == tag]
            stated = [l.max_range for l in tagged if l.max_range]
            names = [n for n in MAX_RANGE_PARAMS.get(tag, ()) if _param_float(log.params, (n,)) is not None]
            if laser_max is not None:
                cap, source = (None, None) if math.isinf(laser_max) else (laser_max, '--laser-max %g m' % laser_max)
            elif stated:
                cap, source = float(min(stated)), 'the max_range field of the %s lines, %g m,' % (tag, min(stated))
            elif names:
                cap = _param_float(log.params, names[:1])
                source = 'PARAM %s %g m' % (names[0], cap)
            else:
                cap, source = None, None
            if cap is not None:
                self.range_max[tag] = cap
            elif self.no_return is not None:
                self.range_max[tag] = self.no_return - NO_RETURN_TOLERANCE
            else:
                self.range_max[tag] = float(max(l.ranges.max() for l in tagged if len(l.ranges)))
            if cap is not None:
                r = np.concatenate([l.ranges for l in tagged])
                beyond = r > cap
                if self.no_return is not None:
                    beyond &= r < self.no_return - NO_RETURN_TOLERANCE
                self.capped[tag] = (source, int(np.sum(beyond)))
        n_inf = sum(int(np.sum(np.isinf(rep117_ranges(l.ranges, self.no_return, self.range_max[l.tag]))))
                    for l in self.lasers)
        self.n_inf = n_inf
        if not self.lasers:
            return
        c = self.no_return_cluster
        if c is not None:
            what = ('no-return readings: the top cluster of the ranges, %.3f-%.3f m (%d readings; %d in the %g m '
                    'below it), +Inf from %.3f m' % (c.low, c.high, c.count, c.below, NO_RETURN_BAND,
                                                     c.low - NO_RETURN_TOLERANCE))
        elif self.no_return is not None:
            what = 'no-return value %.3f m (--no-return), +Inf from %.3f m' % (self.no_return,
                                                                              self.no_return - NO_RETURN_TOLERANCE)
        elif no_return == 'auto':
            what = ('no no-return value found (the top of the ranges is no cluster of at least %d readings within '
                    '%g m with a gap below it and at most %g %% strays above it)'
                    % (NO_RETURN_MIN_COUNT, NO_RETURN_BAND, 100 * NO_RETURN_STRAYS))
        else:
            what = 'no no-return value (--no-return none)'
        self.notes.append('%s; %d readings written as +Inf (REP-117); range_max %s' % (
            what, n_inf, ', '.join('%s %.2f m' % kv for kv in sorted(self.range_max.items()))))
        for tag, (source, n) in sorted(self.capped.items()):
            if n:
                self.notes.append('%s capped %d %s readings to +Inf (readings beyond it%s)' % (
                    source, n, tag, '' if source.startswith('--laser-max') else '; --laser-max overrides'))

    def _check_range(self, stamps, timed_records, time_offset):
        """The stamps, rebuilt ones and --time-offset included, must lie within ROS time."""
        if not len(stamps):
            return
        lo, hi = int(np.argmin(stamps)), int(np.argmax(stamps))
        if stamps[lo] + time_offset <= 0.0:
            raise cc.ConversionError(
                self.log.path, timed_records[lo].line, 'time stamps after 0 s (ROS time; where stamps rebuilt before '
                'the first trustworthy one fall before 0, add --time-offset S or give --line-period S)',
                got='%.6g s' % (stamps[lo] + time_offset))
        if stamps[hi] + time_offset >= cc.ROS_TIME_LIMIT:
            raise cc.ConversionError(
                self.log.path, timed_records[hi].line, 'time stamps before 2^32 s (ROS time holds the seconds as '
                'uint32; --time-offset included)', got='%.6g s' % (stamps[hi] + time_offset))

    def _stamp_notes(self, repair, timed_records, all_lines):
        rebuilt = repair.rebuilt
        if not len(rebuilt):
            return
        trusted = repair.trusted
        lines = [timed_records[i].line for i in rebuilt]
        if len(trusted):
            anchor = 'the first trustworthy stamp (line %d, %.15g s)' % (timed_records[trusted[0]].line,
                                                                        repair.raw[trusted[0]])
        else:
            anchor = '%g s (the log has no trustworthy stamp)' % cc.REBUILT_START
        period = ''
        if repair.line_period is not None:
            period = ('%.6g s per line (%s)' % (repair.line_period, 'given by --line-period' if repair.period_given
                                                else 'measured on the %d trustworthy stamps' % repair.n_trusted))
        if all_lines:
            self.notes.append('time stamps rebuilt from the line order on request (--stamps lines): %d of %d timed '
                              'lines (ODOM, laser and TRUEPOS lines; resets do not count) evenly spaced from %s at %s'
                              % (len(rebuilt), len(timed_records), anchor, period))
            return
        why = '; '.join('%d %s' % (n, reason) for reason, n in repair.reasons().items())
        text = ('time stamps rebuilt from the line order: %d of %d timed lines (ODOM, laser and TRUEPOS lines; resets '
                'do not count) had garbage stamps, from line %d (stamp %.15g) on, the last at line %d: %s'
                % (len(rebuilt), len(timed_records), lines[0], repair.raw[rebuilt[0]], lines[-1], why))
        if len(trusted):
            text += '; interpolated by line number between the trustworthy stamps around them'
        if repair.line_period is not None:
            text += ('; %s at %s' % ('before the first / after the last trustworthy stamp extrapolated' if len(trusted)
                                     else 'spaced from %s' % anchor, period))
        self.notes.append(text)

    def _find_gaps(self, threshold):
        """Consecutive raw ODOM lines more than ``threshold`` seconds apart while the robot moves: the reference
        (interpolated at both ends) moves or turns, the odometry jumps, or the scans in between change. Returns
        (list of dicts, number of such gaps without motion)."""
        t, lines, raw = self.odom_stamps_all, self.odom_lines_all, self.raw_odom_all
        gaps, quiet = [], 0
        if len(t) < 2:
            return gaps, quiet
        rt, ref = self.reference_stamps, self.reference
        ref_yaw = np.unwrap(ref[:, 2]) if len(ref) else None
        scan_lines = np.array([l.line for l in self.lasers], dtype=int)
        for k in np.flatnonzero(np.diff(t) > threshold):
            ta, tb = t[k], t[k + 1]
            gap = {'first_line': int(lines[k]), 'last_line': int(lines[k + 1]), 'duration': float(tb - ta),
                   'reference': None, 'scans': None}
            moved = False
            if len(rt) >= 2 and rt[0] <= ta and tb <= rt[-1]:
                inside = np.flatnonzero((rt > ta) & (rt < tb))
                ts = np.r_[ta, rt[inside], tb]
                x, y, th = (np.interp(ts, rt, ref[:, 0]), np.interp(ts, rt, ref[:, 1]), np.interp(ts, rt, ref_yaw))
                move = float(np.sum(np.hypot(np.diff(x), np.diff(y))))
                turn = float(np.sum(np.abs(np.diff(th))))
                gap['reference'] = (move, turn)
                moved |= move > GAP_MOVE or turn > GAP_TURN
            d = cc.se2_between(raw[k], raw[k + 1])
            gap['odometry'] = (math.hypot(d[0], d[1]), abs(float(d[2])))
            moved |= gap['odometry'][0] > GAP_MOVE or gap['odometry'][1] > GAP_TURN
            between = np.flatnonzero((scan_lines > lines[k]) & (scan_lines < lines[k + 1]))
            if len(between) >= 2:
                a, b = self.lasers[between[0]], self.lasers[between[-1]]
                if a.tag == b.tag and len(a.ranges) == len(b.ranges):
                    ra = rep117_ranges(a.ranges, self.no_return, self.range_max[a.tag])
                    rb = rep117_ranges(b.ranges, self.no_return, self.range_max[b.tag])
                    both = np.isfinite(ra) & np.isfinite(rb)
                    change = float(np.median(np.abs(ra[both] - rb[both]))) if both.any() else 0.0
                    gap['scans'] = (len(between), change)
                    moved |= change > GAP_SCAN_CHANGE
            if moved:
                gaps.append(gap)
            else:
                quiet += 1
        return gaps, quiet

    def _gap_notes(self, threshold):
        if not self.odom_gaps:
            return
        longest = sorted(self.odom_gaps, key=lambda g: -g['duration'])
        self.notes.append('odometry gaps: %d places where two consecutive ODOM lines (resets aside) are more than %g s '
                          'apart (--odom-gap) while the robot moves (the reference moves more than %g m or turns more '
                          'than %g deg, the odometry jumps as much, or the scans in between change), the longest '
                          '%.2f s; %d more such gaps show no motion%s'
                          % (len(self.odom_gaps), threshold, GAP_MOVE, math.degrees(GAP_TURN), longest[0]['duration'],
                             self.n_quiet_gaps, '; the %d longest:' % GAPS_LISTED
                             if len(self.odom_gaps) > GAPS_LISTED else ':'))
        for g in sorted(longest[:GAPS_LISTED], key=lambda g: g['first_line']):
            parts = []
            if g['reference'] is not None:
                parts.append('reference moves %.2f m and turns %.0f deg' % (g['reference'][0],
                                                                           math.degrees(g['reference'][1])))
            parts.append('odometry %s %.2f m and %.0f deg' % (
                'jumps' if g['odometry'][0] > GAP_MOVE or g['odometry'][1] > GAP_TURN else 'moves',
                g['odometry'][0], math.degrees(g['odometry'][1])))
            if g['scans'] is not None:
                parts.append('%d scans in between, ranges change by %.2f m (median)' % g['scans'])
            self.notes.append('odometry gap, lines %d-%d: %.2f s without ODOM; %s'
                              % (g['first_line'], g['last_line'], g['duration'], '; '.join(parts)))


def laser_max_arg(text):
    """--laser-max: a positive number of metres, or none / 0 (no cap: 0.0)."""
    if text.strip().lower() == 'none':
        return 0.0
    try:
        v = float(text)
    except ValueError:
        v = float('nan')
    if not (v >= 0.0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError('expected metres (a positive number), or none or 0 for no cap, got %r'
                                         % text)
    return v


def build_parser():
    p = cc.make_parser('carmen_to_bag', __doc__)
    p.add_argument('log', help='CARMEN log, plain or gzip-compressed')
    p.add_argument('--corrected', choices=('auto', 'yes', 'no'), default='auto',
                   help='whether ODOM lines after laser lines reset odometry to a corrected pose (default auto); '
                        'no: every ODOM line is raw odometry, also where the laser lines repeat their poses')
    p.add_argument('--laser-poses', choices=('auto', 'reference', 'odometry', 'ignore'), default='auto',
                   help='what the robot poses of the laser lines are: auto = the reference path in a corrected log '
                        'or a log without ODOM lines, else ignored')
    p.add_argument('--no-odometry', action='store_true',
                   help='write no odometry (the scans and the reference only): for a log without raw odometry')
    p.add_argument('--line-period', type=cc.positive_float, default=None, metavar='S',
                   help='seconds from one timed line (ODOM, laser, TRUEPOS) to the next, to rebuild garbage stamps '
                        '(default: measured on the log\'s trustworthy stamps; needed when they do not advance)')
    p.add_argument('--stamps', choices=('log', 'lines'), default='log',
                   help='log: the log\'s stamps, garbage ones rebuilt from the line order (default); lines: every '
                        'stamp rebuilt from the line order, evenly spaced')
    p.add_argument('--odom-gap', type=cc.positive_float, default=1.0, metavar='S',
                   help='report consecutive ODOM lines more than S seconds apart while the robot moves (default 1)')
    p.add_argument('--no-return', default='auto', metavar='M',
                   help='reading [m] that means no return (-> +Inf, and readings above it); auto = the lower edge of '
                        'the top cluster of the log\'s readings (at least %d readings within %g m, a gap below); '
                        'none = no such value' % (NO_RETURN_MIN_COUNT, NO_RETURN_BAND))
    p.add_argument('--laser-max', type=laser_max_arg, default=None, metavar='M',
                   help='the lasers\' maximum range [m]: readings beyond it become +Inf; overrides the log\'s cap (the '
                        'max_range field of ROBOTLASER1 lines, or a PARAM such as robot_front_laser_max); none or 0: '
                        'no cap, only no-returns become +Inf (default: the log\'s cap)')
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
    conv = Conversion(log, corrected=args.corrected, laser_poses=args.laser_poses, no_return=args.no_return,
                      line_period=args.line_period, stamps=args.stamps, no_odometry=args.no_odometry,
                      odom_gap=args.odom_gap, time_offset=args.time_offset, laser_max=args.laser_max)
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
