"""Victoria Park (Guivant and Nebot, ACFR, University of Sydney) to a rosbag: a utility car driving about 4 km
among the park's trees with a 2D laser, its speed and steering, and GPS.

Input: a folder holding ``victoria_park_ascii.zip`` (the ASCII release as distributed, read as it is) or the files
extracted from it (``LASER.txt``, ``DRS.txt``, ``GPS.txt``; plain or gzip), or the zip itself; with ``--detections``
also the tree detections ``published_measurements.dat[.gz]``.

* ``LASER.txt``: one whitespace-separated stream (a single line as distributed; a scan a line works too) of 362
  numbers a scan: the time [s], then 361 ranges [m] over 0-180 deg at 0.5 deg steps, beam 0 to the car's right,
  beam 180 straight ahead. Written as ``scan`` (sensor_msgs/LaserScan) in the frame ``laser``, whose x axis points
  ahead: angle_min -pi/2, increment 0.5 deg. The SICK scanner reports "no return" and its error cases as the
  largest values it can give (81.83-81.91 m here): the readings in the top cluster, within NO_RETURN_BAND (0.1 m)
  of the log's largest reading when at least NO_RETURN_MIN_COUNT readings lie there, become +Inf (REP-117), and
  range_max is 1 cm below the cluster; readings <= 0 are NaN. A scan whose time is not after the one before means
  that a scan before it has more or fewer than 361 ranges, which shifts every later scan in the stream: that stops
  the conversion even with ``--skip-bad``.
* ``DRS.txt``: ``time speed steering`` at 40 Hz: the speed [m/s] of the left rear wheel, whose encoder sits H =
  0.76 m left of the rear axle's centre, and the steering angle [rad], positive to the left. Odometry is the
  bicycle model about the rear axle (``base_link`` = the rear axle's centre, wheelbase L = 2.83 m): axle-centre
  speed v_c = v / (1 - tan(steering) H / L) (the left wheel runs on the inside of a left turn), heading rate
  v_c tan(steering) / L, each line's values held until the next line's time (exact arcs). ``odom``
  (nav_msgs/Odometry; twist: v_c and the heading rate of the step ending at the stamp) and TF
  ``odom -> base_link`` at every line, from the identity at the first.
* ``/tf_static`` ``base_link -> laser``: the laser is a = 0.95 m ahead of the front axle and b = 0.5 m left of the
  centre line, i.e. at (L + a, b) = (3.78, 0.5) m.
* ``GPS.txt``: ``time north east`` [s, m, m] in a local metric frame (its Documentation.txt names the columns
  GPSLat and GPSLon): the reference, ``ground_truth/odom`` (positions only, orientation identity, child frame
  ``gps``) and ``ground_truth/path`` (latched) in the frame ``map``, x east and y north (REP-103). Read as (x, y)
  the columns would mirror the drive: the dead-reckoning error after a rigid fit is 104 m that way, 57 m this way.
  The GPS frame is not the odometry's start frame (the start heading is unknown): compare after a rigid fit,
  as evaluate_bag_run does by default. The antenna's place on the car is not stated: it is compared at base_link.
  The fixes are sparse (948, gaps of up to three minutes under the trees).
* ``--detections``: the tree detections distributed with the RFS-SLAM code of Leung et al. (``time range bearing
  diameter``; bearing 0..pi across the scan like the laser's beams): a ``landmarks`` rbpf_slam/TrunkArray in the
  frame ``laser`` at every scan, empty where the scan has none, with centre (r cos b, r sin b) for b = bearing -
  pi/2, radius = diameter / 2, METHOD_GIVEN, id -1, the covariance of the centre from the range and bearing noise
  that code's configuration states (variances 0.025 m^2 and 0.000025 rad^2: ``--range-sigma`` 0.158 m,
  ``--bearing-sigma`` 0.005 rad) and the radius variance from its diameter variance (0.002 m^2 / 4). Each array
  states the detector's scope from that configuration: 1.45-70 m, bearings 6.3025-177 deg (-83.6975 to +87 deg
  in the laser frame), detection probability 0.9. Detections timed outside the laser log are skipped (the file
  runs 4 s past LASER.txt).

Stamps are the data set's own seconds (GPS from 0.0, laser from 0.852, DRS from 0.973) plus ``--time-offset``,
by default 1 s (ROS time 0 is no time: rosbag refuses it, TF reads it as "the latest"). ``Sensors_manager.txt`` (the order the streams were logged in) is not needed: the stamps give it.
"""
import io
import math
import os
import zipfile

import numpy as np

from rbpf_slam import convert_common as cc

WHEELBASE = 2.83                  # [m] L, rear to front axle
ENCODER_LEFT = 0.76               # [m] H, the speed encoder (left rear wheel) left of the rear axle's centre
LASER_AHEAD_OF_FRONT_AXLE = 0.95  # [m] a
LASER_LEFT = 0.5                  # [m] b, left of the centre line
LASER_MOUNT = (WHEELBASE + LASER_AHEAD_OF_FRONT_AXLE, LASER_LEFT)  # [m] in base_link (the rear axle's centre)
#: A steering angle beyond this is no reading of the car's (its lock is about 0.6 rad; v_c is singular at 1.31 rad).
MAX_STEERING = 1.0                # [rad]
#: A wheel speed beyond this is no reading of a utility car driving in a park (the log's fastest is 6.6 m/s).
MAX_SPEED = 30.0                  # [m/s]

BEAMS = 361
ANGLE_MIN = -math.pi / 2.0        # [rad] beam 0, to the car's right
BEAM_INCREMENT = math.radians(0.5)
SCAN_FIELDS = 1 + BEAMS           # the time and the ranges
#: The no-return readings: within this of the log's largest reading, when at least NO_RETURN_MIN_COUNT readings are.
NO_RETURN_BAND = 0.1              # [m]
NO_RETURN_MIN_COUNT = 10
RANGE_RESOLUTION = 0.01           # [m] of the ranges as written

#: The tree detections' sensor model and scope, as the RFS-SLAM configuration for them states it.
DETECTION_RANGE_SIGMA = math.sqrt(0.025)      # [m]
DETECTION_BEARING_SIGMA = math.sqrt(0.000025)  # [rad]
DETECTION_DIAMETER_VARIANCE = 0.002           # [m^2]
DETECTION_RANGE_MIN = 1.45                    # [m]
DETECTION_RANGE_MAX = 70.0                    # [m]
DETECTION_BEARING_MIN = math.radians(6.3025)  # [rad] across the scan, 0 to the car's right
DETECTION_BEARING_MAX = math.radians(177.0)   # [rad]
DETECTION_PROBABILITY = 0.9

ARCHIVE = 'victoria_park_ascii.zip'
LASER_FILE, DRS_FILE, GPS_FILE = 'LASER.txt', 'DRS.txt', 'GPS.txt'
DETECTIONS_FILE = 'published_measurements.dat'

EXAMPLE = """
Example:
  victoria_park_to_bag $RBPF_SLAM_DATA/victoria_park -o victoria_park.bag --detections
  rosbag play --clock victoria_park.bag   # /odom, /tf, /tf_static, /scan, /landmarks, /ground_truth/{odom,path}
  victoria_park_to_bag victoria_park_ascii.zip -o vp.bag --limit 500      # the first 500 scans
"""


# --- Reading the release ---------------------------------------------------------------------------


class Release:
    """The ASCII files, from the zip archive or a folder of the extracted files. ``open(name)`` gives (the path
    that names the file in messages, an open text stream or None for a plain file that read_tokens opens)."""

    def __init__(self, source, explicit=None):
        self.explicit = dict(explicit or {})
        self.archive_path = None
        self.archive = None
        self.directory = source
        if os.path.isfile(source):
            self.archive_path, self.directory = source, os.path.dirname(source)
        elif os.path.isdir(source):
            zip_path = os.path.join(source, ARCHIVE)
            if os.path.isfile(zip_path) and not all(self.explicit.get(n) for n in (LASER_FILE, DRS_FILE, GPS_FILE)):
                self.archive_path = zip_path
        else:
            cc.input_file(source)  # names what is missing
        if self.archive_path:
            try:
                self.archive = zipfile.ZipFile(self.archive_path)
            except zipfile.BadZipFile as e:
                raise cc.ConversionError(self.archive_path, None, 'a zip archive (the ASCII release)',
                                         got='a damaged or cut-short file (%s)' % e)

    def describe(self):
        return 'the archive %s' % self.archive_path if self.archive else 'the folder %s' % self.directory

    def close(self):
        if self.archive is not None:
            self.archive.close()

    def open(self, name):
        if self.explicit.get(name):
            return cc.input_file(self.explicit[name]), None
        if self.archive is None:
            return cc.input_file(cc.with_gz(self.directory, name)), None
        members = [i for i in self.archive.infolist() if os.path.basename(i.filename).lower() == name.lower()]
        if not members:
            names = ', '.join(os.path.basename(i.filename) for i in self.archive.infolist()) or 'none'
            raise cc.ConversionError(self.archive_path, None, '%s in the archive' % name, got='members %s' % names)
        info = members[0]
        path = '%s/%s' % (self.archive_path, info.filename)
        try:
            with self.archive.open(info) as f:
                head = f.read(4096)
        except cc.COMPRESSION_ERRORS as e:
            raise cc.ConversionError(path, 1, 'more data (the compressed file is cut short or damaged)', got=e)
        if b'\x00' in head:
            raise cc.ConversionError(path, None, 'a text log', got='binary data (NUL bytes)')
        return path, io.TextIOWrapper(self.archive.open(info), encoding='latin-1', newline=None)


def _token_pieces(f, path, chunk=1 << 20):
    """``(line number, tokens)`` of a text stream read ``chunk`` characters at a time: a line comes whole, or in
    several pieces with its number when it is longer than a chunk (LASER.txt as distributed is one line of 15 MB)."""
    line, carry = 1, ''
    while True:
        try:
            data = f.read(chunk)
        except cc.COMPRESSION_ERRORS as e:
            raise cc.ConversionError(path, line, 'more data (the compressed file is cut short or damaged)', got=e)
        if not data:
            if carry.split():
                yield line, carry.split()
            return
        data = carry + data
        cut = max(data.rfind(c) for c in ' \t\n\r\f\v') + 1  # keep a token the chunk ends in for the next one
        data, carry = data[:cut], data[cut:]
        parts = data.split('\n')
        for i, part in enumerate(parts):
            tokens = part.split()
            if tokens:
                yield line + i, tokens
        line += len(parts) - 1


def _number(token):
    try:
        value = float(token)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def read_laser(path, bad=None, limit=None, stream=None):
    """The scans of LASER.txt: (stamps (n,), ranges (n, 361) [m], line of each scan's time). ``limit``: the first
    N scans. A malformed range skips its scan with ``--skip-bad``; a time that is not a number after the previous
    scan's stops the conversion in any case (the scans before it do not have 361 ranges each)."""
    bad = bad or cc.BadLines()
    stamps, scans, lines = [], [], []
    current, first_line, previous, n_scans = [], None, None, 0
    with cc.open_text(path) if stream is None else stream as f:
        for line, tokens in _token_pieces(f, path):
            i = 0
            while i < len(tokens):
                if not current:
                    first_line = line
                take = tokens[i:i + SCAN_FIELDS - len(current)]
                current.extend(take)
                i += len(take)
                if len(current) < SCAN_FIELDS:
                    continue
                n_scans += 1
                t = _number(current[0])
                if t is None or (previous is not None and t <= previous):
                    raise cc.ConversionError(
                        path, first_line, 'the time of scan %d%s (a time and %d ranges a scan)' % (
                            n_scans, ' after %.3f s' % previous if previous is not None else '', BEAMS),
                        got=cc.quote(current[0]))
                try:
                    r = cc.parse_floats(current[1:], path, first_line, 'numbers as the %d ranges of scan %d'
                                        % (BEAMS, n_scans))
                except cc.ConversionError as e:
                    bad(e)
                else:
                    stamps.append(t)
                    scans.append(r)
                    lines.append(first_line)
                previous = t
                current = []
                if limit is not None and len(stamps) >= limit:
                    return np.array(stamps), np.array(scans), np.array(lines)
    if current:
        bad(cc.ConversionError(path, first_line, 'a time and %d ranges (%d numbers) in scan %d' % (
            BEAMS, SCAN_FIELDS, n_scans + 1), got='%d value%s (the file ends)' % (
                len(current), '' if len(current) == 1 else 's')))
    if not stamps:
        raise cc.ConversionError(path, None, 'scans of a time and %d ranges' % BEAMS,
                                 got='no whole scan' if n_scans or current else 'an empty file')
    return np.array(stamps), np.array(scans), np.array(lines)


def read_drs(path, bad=None, until=None, stream=None):
    """DRS.txt: (stamps, speed [m/s] of the left rear wheel, steering [rad]); up to the first line at or after
    ``until``. A steering angle beyond MAX_STEERING or a speed beyond MAX_SPEED is malformed."""
    bad = bad or cc.BadLines()
    rows, lines = cc.read_table(path, ('time', 'speed', 'steering'), bad, until=until, one_past=True,
                                order='increase', stream=stream)
    speed_ok = np.abs(rows[:, 1]) <= MAX_SPEED
    ok = speed_ok & (np.abs(rows[:, 2]) <= MAX_STEERING)
    for k in np.flatnonzero(~ok):
        if not speed_ok[k]:
            bad(cc.ConversionError(path, int(lines[k]), 'a speed within +-%g m/s' % MAX_SPEED, got='%g' % rows[k, 1]))
        else:
            bad(cc.ConversionError(path, int(lines[k]), 'a steering angle within +-%g rad' % MAX_STEERING,
                                   got='%g' % rows[k, 2]))
    rows = rows[ok]
    if not len(rows):
        raise cc.ConversionError(path, None, 'lines of time speed steering', got='no valid line')
    return rows[:, 0], rows[:, 1], rows[:, 2]


def read_gps(path, bad=None, until=None, stream=None):
    """GPS.txt: (stamps, x east [m], y north [m]) from its ``time north east`` columns."""
    rows, _ = cc.read_table(path, ('time', 'north', 'east'), bad, until=until, one_past=True, order='increase',
                            stream=stream)
    return rows[:, 0], rows[:, 2], rows[:, 1]


def read_detections(path, bad=None, until=None):
    """published_measurements.dat: an (n, 4) array time, range [m], bearing [rad, 0..pi across the scan],
    diameter [m], and the line of each row."""
    return cc.read_table(path, ('time', 'range', 'bearing', 'diameter'), bad, until=until, order='not decrease')


# --- The models ------------------------------------------------------------------------------------


def axle_speed(speed, steering, wheelbase=WHEELBASE, encoder_left=ENCODER_LEFT):
    """Speed of the rear axle's centre from the left rear wheel's: v / (1 - tan(steering) H / L)."""
    return np.asarray(speed, dtype=float) / (1.0 - np.tan(steering) * encoder_left / wheelbase)


def bicycle_odometry(stamps, speed, steering, wheelbase=WHEELBASE, encoder_left=ENCODER_LEFT):
    """Poses of the rear axle's centre at each DRS stamp (x, y, theta; the first the identity), each line's speed
    and steering held until the next stamp, and the axle-centre speed and heading rate of the step ending at each
    stamp (0 for the first)."""
    vc = axle_speed(speed, steering, wheelbase, encoder_left)
    w = vc * np.tan(steering) / wheelbase
    x, y, th, _, _ = cc.integrate_velocities(stamps, vc, w)
    return x, y, th, np.r_[0.0, vc[:-1]], np.r_[0.0, w[:-1]]


def no_return_threshold(scans, band=NO_RETURN_BAND, min_count=NO_RETURN_MIN_COUNT):
    """The lowest reading that means "no return": ``band`` below the largest reading, when at least ``min_count``
    readings lie in that top cluster; None when fewer do (every reading is then a return). Returns (threshold,
    number of readings in the cluster)."""
    scans = np.asarray(scans, dtype=float)
    if scans.size == 0:
        return None, 0
    threshold = float(np.max(scans)) - band
    n = int(np.sum(scans >= threshold - 1e-9))
    return (threshold, n) if n >= min_count else (None, 0)


def scan_to_rep117(ranges, threshold):
    """Ranges in REP-117 form: the no-return cluster (>= threshold) +Inf, readings <= 0 NaN."""
    r = np.array(ranges, dtype=float)
    if threshold is not None:
        r[r >= threshold - 1e-9] = np.inf
    r[r <= 0.0] = np.nan
    return r


def detection_scope():
    """The detector's scope in the laser frame (TrunkArray fields)."""
    return {'min_range': DETECTION_RANGE_MIN, 'max_range': DETECTION_RANGE_MAX,
            'fov_min': DETECTION_BEARING_MIN - math.pi / 2.0, 'fov_max': DETECTION_BEARING_MAX - math.pi / 2.0,
            'detection_probability': DETECTION_PROBABILITY}


def group_by_time(rows):
    """Rows (time first, non-decreasing) as {time: rows of that time}."""
    out = {}
    if len(rows):
        cuts = np.flatnonzero(np.diff(rows[:, 0]) != 0) + 1
        for part in np.split(rows, cuts):
            out[float(part[0, 0])] = part
    return out


# --- The command -----------------------------------------------------------------------------------


def build_parser():
    p = cc.make_parser('victoria_park_to_bag', __doc__)
    p.add_argument('directory', help='folder with %s or its extracted files (or the zip itself)' % ARCHIVE)
    p.add_argument('--laser', help='LASER.txt (default: in the archive, else DIRECTORY/LASER.txt)')
    p.add_argument('--drs', help='DRS.txt (default: in the archive, else DIRECTORY/DRS.txt)')
    p.add_argument('--gps', help='GPS.txt (default: in the archive, else DIRECTORY/GPS.txt)')
    p.add_argument('--no-gps', action='store_true', help='write no reference')
    p.add_argument('--detections', nargs='?', const='', default=None, metavar='FILE',
                   help='write the tree detections on the landmarks topic (default file: DIRECTORY/%s[.gz])'
                        % DETECTIONS_FILE)
    p.add_argument('--range-sigma', type=cc.positive_float, default=DETECTION_RANGE_SIGMA,
                   help='range noise of the detections [m] (default %.3f)' % DETECTION_RANGE_SIGMA)
    p.add_argument('--bearing-sigma', type=cc.positive_float, default=DETECTION_BEARING_SIGMA,
                   help='bearing noise of the detections [rad] (default %.3f)' % DETECTION_BEARING_SIGMA)
    cc.add_common_arguments(
        p, time_offset=cc.ZERO_CLOCK_OFFSET,
        topics=(('--odom-topic', 'odom', 'nav_msgs/Odometry'),
                ('--scan-topic', 'scan', 'sensor_msgs/LaserScan'),
                ('--landmarks-topic', 'landmarks', 'rbpf_slam/TrunkArray, the tree detections (--detections)'),
                ('--truth-odom-topic', 'ground_truth/odom', 'nav_msgs/Odometry, the GPS fixes'),
                ('--truth-path-topic', 'ground_truth/path', 'nav_msgs/Path, all GPS fixes (once, at the end)')),
        frames=(('--odom-frame', 'odom', 'odometry frame'),
                ('--base-frame', 'base_link', 'car frame (the rear axle\'s centre)'),
                ('--laser-frame', 'laser', 'laser frame, also of the detections'),
                ('--map-frame', 'map', 'frame of the GPS (x east, y north)'),
                ('--truth-point-frame', 'gps', 'child frame of the GPS fixes')))
    p.epilog = ('A record for --limit is a scan; the other files are read up to the last of those scans.\n'
                + EXAMPLE)
    return p


def _detections_path(args):
    if args.detections:
        return cc.input_file(args.detections)
    directory = args.directory if os.path.isdir(args.directory) else os.path.dirname(args.directory)
    return cc.input_file(cc.with_gz(directory, DETECTIONS_FILE))


def convert(args, out, bad, summary):
    release = Release(args.directory, {LASER_FILE: args.laser, DRS_FILE: args.drs, GPS_FILE: args.gps})
    try:
        _convert(args, release, out, bad, summary)
    finally:
        release.close()


def _convert(args, release, out, bad, summary):
    from rbpf_slam import convert_msgs as m
    detections_path = _detections_path(args) if args.detections is not None else None
    summary.note('read from %s' % release.describe())

    path, stream = release.open(LASER_FILE)
    t_scan, scans, scan_lines = read_laser(path, bad, args.limit, stream)
    until = float(t_scan[-1]) if args.limit else None
    span = (float(t_scan[0]), float(t_scan[-1]))
    threshold, n_inf = no_return_threshold(scans)
    range_max = threshold - RANGE_RESOLUTION if threshold is not None else float(np.nanmax(scans))
    if threshold is not None:
        cluster = scans[scans >= threshold - 1e-9]
        values, counts = np.unique(np.round(cluster, 3), return_counts=True)
        summary.note('no returns: the top cluster of readings, %.2f-%.2f m (%s), %d of %d readings: written as +Inf; '
                     'range_max %.2f m' % (values[0], values[-1], ', '.join('%.2f m: %d' % vc for vc in zip(
                         values[::-1][:6], counts[::-1][:6])), n_inf, scans.size, range_max))
    else:
        summary.note('no no-return cluster (fewer than %d readings within %.2f m of the largest): every reading is a '
                     'return; range_max %.2f m' % (NO_RETURN_MIN_COUNT, NO_RETURN_BAND, range_max))

    path, stream = release.open(DRS_FILE)
    t_odo, speed, steering = read_drs(path, bad, until, stream)
    cc.check_same_clock(path, None, t_odo, span, LASER_FILE)
    x, y, th, vc, w = bicycle_odometry(t_odo, speed, steering)
    length = float(np.sum(np.hypot(np.diff(x), np.diff(y))))
    summary.note('odometry: %d DRS lines, %.0f m driven (%.0f s); bicycle model about the rear axle, L %.2f m, the '
                 'encoder wheel H %.2f m left of the axle\'s centre: v_c = v / (1 - tan(steering) H / L)'
                 % (len(t_odo), length, t_odo[-1] - t_odo[0], WHEELBASE, ENCODER_LEFT))

    gps = None
    if not args.no_gps:
        path, stream = release.open(GPS_FILE)
        gps = read_gps(path, bad, until, stream)
        cc.check_same_clock(path, None, gps[0], span, LASER_FILE)
        gaps = np.diff(gps[0])
        summary.note('reference: %d GPS fixes (x east = the 3rd column, y north = the 2nd), gaps up to %.0f s; '
                     'positions only, in the GPS\'s frame: compare after a rigid fit' % (
                         len(gps[0]), gaps.max() if len(gaps) else 0.0))

    arrays = None
    if detections_path is not None:
        rows, _ = read_detections(detections_path, bad, until)
        if len(rows):
            cc.check_same_clock(detections_path, None, rows[:, 0], span, LASER_FILE)
        inside = (rows[:, 0] >= span[0]) & (rows[:, 0] <= span[1])
        groups = group_by_time(rows[inside])
        outside = group_by_time(rows[~inside])
        summary.skip('detections timed outside the laser log (%d times)' % len(outside), int(np.sum(~inside)))
        empty = [float(t) for t in t_scan if float(t) not in groups]
        for t in empty:
            groups[t] = rows[:0]
        arrays = sorted(groups.items())
        summary.note('detections: %d at %d times in the laser frame (bearing - pi/2), %d scans without one (empty '
                     'arrays), %d times that are no scan\'s; sigma range %.3f m, bearing %.4f rad; scope %.2f-%.0f m, '
                     '%.4f to %.4f rad, detection probability %.2f' % (
                         int(np.sum(inside)), len(arrays) - len(empty), len(empty),
                         len(set(groups) - set(float(t) for t in t_scan)), args.range_sigma, args.bearing_sigma,
                         DETECTION_RANGE_MIN, DETECTION_RANGE_MAX, detection_scope()['fov_min'],
                         detection_scope()['fov_max'], DETECTION_PROBABILITY))

    starts = [t_scan[0], t_odo[0]] + ([gps[0][0]] if gps is not None else [])
    t0 = float(min(starts))
    out.expect(1 + 2 * len(t_odo) + len(t_scan) + (len(gps[0]) + 1 if gps is not None else 0)
               + (len(arrays) if arrays is not None else 0))
    scope = detection_scope()

    def statics():
        yield t0, '/tf_static', m.tf_message(m.transform(t0, args.base_frame, args.laser_frame, LASER_MOUNT[0],
                                                         LASER_MOUNT[1], 0.0)), True

    def odometry():
        for i in range(len(t_odo)):
            t = float(t_odo[i])
            pose = float(x[i]), float(y[i]), float(th[i])
            yield t, args.odom_topic, m.odometry(t, args.odom_frame, args.base_frame, *pose, v=float(vc[i]),
                                                 w=float(w[i])), False
            yield t, '/tf', m.tf_message(m.transform(t, args.odom_frame, args.base_frame, *pose)), False

    def laser():
        for i in range(len(t_scan)):
            t = float(t_scan[i])
            yield t, args.scan_topic, m.laser_scan(t, args.laser_frame, ANGLE_MIN, BEAM_INCREMENT,
                                                   scan_to_rep117(scans[i], threshold).tolist(), 0.0,
                                                   range_max), False

    def truth():
        if gps is not None:
            yield from cc.position_reference(args, *gps)

    def detections():
        for t, part in arrays or ():
            trunks = []
            for _, r, bearing, diameter in part:
                b = float(bearing) - math.pi / 2.0
                r = float(r)
                trunks.append(m.trunk(r * math.cos(b), r * math.sin(b), radius=float(diameter) / 2.0,
                                      radius_variance=DETECTION_DIAMETER_VARIANCE / 4.0,
                                      covariance=cc.polar_covariance(r, b, args.range_sigma, args.bearing_sigma),
                                      range_=r, bearing=b))
            yield t, args.landmarks_topic, m.trunk_array(t, args.laser_frame, trunks, scope), False

    out.write_merged([statics(), odometry(), laser(), truth(), detections()])


def main(argv=None):
    return cc.run(build_parser(), convert, argv)
