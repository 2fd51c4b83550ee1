"""ESE 650 / "Intelligent Autonomous Systems" skid-steer robot runs (MATLAB .mat files) to a rosbag.

Inputs of one run N (``Encoders<N>.mat``, ``imu<N>.mat``, optional ``Hokuyo<N>.mat``):

* ``Encoders``: struct with ``counts`` (4 x K integers, wheel order FR FL RR RL, counts since the
  previous read, forward motion positive) and ``ts`` (1 x K Unix seconds), about 40 Hz.
* ``imu``: ``ts`` (1 x M) and ``vals`` (6 x M: accx accy accz in g, gyrx gyry gyrz in rad/s), 100 Hz.
* ``Hokuyo0`` (optional; the data set's Hokuyo UTM-30LX file): struct with ``ranges`` (1081 x S, m),
  ``angles`` (1081 x 1, rad, -135 to +135 deg, counter-clockwise, 0 = forward) and ``ts`` (1 x S).

Written:

* ``odom`` (nav_msgs/Odometry) and TF ``odom -> base_link``, one per encoder read: skid-steer dead
  reckoning, left = mean(FL, RL), right = mean(FR, RR), each count 254 mm * pi / 360 = 2.2166 mm of
  wheel travel (360 counts per revolution, 254 mm wheels: ``platform_config.pdf``), exact arcs with
  dtheta = (right - left) / effective track. Skid steering slips, so the effective track is wider than
  the wheels' (311.15 mm inner, 476.25 mm outer): the default ``--track`` 0.7283 m is 1.85 x their
  mean (393.7 mm), the common estimate the data's README names. It is a parameter, never fitted here.
* ``wheel_ticks`` (sensor_msgs/JointState), one per encoder read: names ``front_right_wheel
  front_left_wheel rear_right_wheel rear_left_wheel`` (the file's order), ``position`` = the wheel's
  cumulative angle in rad since the start = cumulative counts * 2 pi / 360, so the raw counts are
  exactly ``round(position * 360 / (2 pi))`` and the increments of a read their differences;
  ``velocity`` = the increment of this read / its interval [rad/s].
* ``imu/data`` (sensor_msgs/Imu, frame ``base_link``: the IMU's axes are the robot's, z up, as the
  data shows: +1 g on z at rest, gyro z turning with the wheels): accelerations times 9.80665 m/s^2,
  rates as given, no orientation (orientation_covariance[0] = -1).
* ``scan`` (sensor_msgs/LaserScan, frame ``laser``) from the Hokuyo file: angles from the file
  (uniform spacing required), range_min 0.1 m and range_max 30 m (UTM-30LX); readings above range_max
  are +Inf, below range_min NaN (the UTM-30LX reports errors as tiny values), REP-117. scan_time
  0.025 s and time_increment 0.025 / 1440 s (40 Hz, 1440 steps per turn).
* ``/tf_static`` ``base_link -> laser``: from ``platform_config.pdf``: the lidar is 298.33 mm ahead of
  the rear axle (the sheet's origin) and 514.35 mm above it; ``base_link`` is the centre of the wheel
  base, 330.20 / 2 mm ahead of the rear axle at axle height, so the laser is at (0.13323, 0, 0.51435) m.

No ground truth exists for these runs. Stamps are the files' Unix times.
"""
import math
import os

import numpy as np

from rbpf_slam import convert_common as cc

COUNTS_PER_REV = 360
WHEEL_DIAMETER = 0.254                          # [m]
METRES_PER_COUNT = math.pi * WHEEL_DIAMETER / COUNTS_PER_REV
TRACK_INNER, TRACK_OUTER = 0.31115, 0.47625     # [m]
TRACK_SLIP_FACTOR = 1.85
DEFAULT_TRACK = TRACK_SLIP_FACTOR * (TRACK_INNER + TRACK_OUTER) / 2.0  # 0.7283 m
WHEEL_NAMES = ('front_right_wheel', 'front_left_wheel', 'rear_right_wheel', 'rear_left_wheel')
LIDAR_AHEAD_OF_REAR_AXLE = 0.29833              # [m]
LIDAR_ABOVE_AXLE = 0.51435                      # [m]
WHEEL_BASE = 0.33020                            # [m]
LASER_MOUNT = (LIDAR_AHEAD_OF_REAR_AXLE - WHEEL_BASE / 2.0, 0.0, LIDAR_ABOVE_AXLE)
HOKUYO_RANGE_MIN, HOKUYO_RANGE_MAX = 0.1, 30.0  # [m] UTM-30LX
HOKUYO_SCAN_TIME = 0.025                        # [s]
HOKUYO_STEPS_PER_TURN = 1440

EXAMPLE = """
Example:
  ese650_to_bag $RBPF_SLAM_DATA/ese650 20 -o ese20.bag               # odometry, ticks, IMU
  ese650_to_bag $RBPF_SLAM_DATA/ese650 20 --hokuyo Hokuyo20.mat -o ese20.bag
  rosbag play --clock ese20.bag
"""


def _loadmat(path):
    import scipy.io
    cc.input_file(path)
    try:
        return scipy.io.loadmat(path, squeeze_me=False, struct_as_record=True)
    except Exception as e:  # scipy raises ValueError, TypeError, ... for what is not a .mat file
        raise cc.ConversionError(path, None, 'a MATLAB .mat file', got='%s: %s' % (type(e).__name__, e))


def _describe(mat):
    keys = [k for k in mat if not k.startswith('__')]
    parts = []
    for k in keys:
        v = mat[k]
        if isinstance(v, np.ndarray) and v.dtype.names:
            parts.append('%s{%s}' % (k, ','.join(v.dtype.names)))
        else:
            parts.append('%s %s' % (k, 'x'.join(str(d) for d in getattr(v, 'shape', ()))))
    return ', '.join(parts) or 'no variables'


def _struct_field(mat, path, struct, field, expected):
    v = mat.get(struct)
    if not (isinstance(v, np.ndarray) and v.dtype.names and field in v.dtype.names and v.size >= 1):
        raise cc.ConversionError(path, None, expected, got=_describe(mat))
    return np.asarray(v.flat[0][field])


def _row(a, path, expected, mat):
    a = np.asarray(a)
    if a.ndim == 2 and 1 in a.shape:
        return a.reshape(-1)
    if a.ndim == 1:
        return a
    raise cc.ConversionError(path, None, expected, got=_describe(mat))


def load_encoders(path):
    """(ts [s], counts (4, K) int64) from an Encoders .mat file."""
    expected = "a struct 'Encoders' with fields 'counts' (4 x K integers: FR FL RR RL) and 'ts' (1 x K seconds)"
    mat = _loadmat(path)
    counts = _struct_field(mat, path, 'Encoders', 'counts', expected)
    ts = _row(_struct_field(mat, path, 'Encoders', 'ts', expected), path, expected, mat)
    if counts.ndim != 2 or counts.shape[0] != 4 or counts.shape[1] != ts.size or ts.size == 0:
        raise cc.ConversionError(path, None, expected, got='counts %s, ts of %d' % (
            'x'.join(map(str, counts.shape)), ts.size))
    if not np.issubdtype(counts.dtype, np.number) or not np.all(np.isfinite(ts)):
        raise cc.ConversionError(path, None, expected, got='counts of type %s' % counts.dtype)
    if np.any(np.diff(ts) <= 0):
        raise cc.ConversionError(path, None, 'increasing encoder time stamps',
                                 got='%d steps back or repeated' % int(np.sum(np.diff(ts) <= 0)))
    return ts.astype(float), counts.astype(np.int64)


def load_imu(path):
    """(ts [s], vals (6, M)) from an imu .mat file."""
    expected = "variables 'ts' (1 x M seconds) and 'vals' (6 x M: acc x y z [g], gyro x y z [rad/s])"
    mat = _loadmat(path)
    if 'ts' not in mat or 'vals' not in mat:
        raise cc.ConversionError(path, None, expected, got=_describe(mat))
    ts = _row(mat['ts'], path, expected, mat)
    vals = np.asarray(mat['vals'])
    if vals.ndim != 2 or vals.shape[0] != 6 or vals.shape[1] != ts.size or ts.size == 0:
        raise cc.ConversionError(path, None, expected, got=_describe(mat))
    if np.any(np.diff(ts) <= 0):
        raise cc.ConversionError(path, None, 'increasing IMU time stamps',
                                 got='%d steps back or repeated' % int(np.sum(np.diff(ts) <= 0)))
    return ts.astype(float), vals.astype(float)


def load_hokuyo(path):
    """(ts [s], ranges (S, n) [m], angles (n,) [rad]) from a Hokuyo .mat file (struct Hokuyo0)."""
    expected = ("a struct 'Hokuyo0' with fields 'ranges' (n x S metres), 'angles' (n x 1 rad) and 'ts' "
                "(1 x S seconds)")
    mat = _loadmat(path)
    ranges = _struct_field(mat, path, 'Hokuyo0', 'ranges', expected)
    angles = _row(_struct_field(mat, path, 'Hokuyo0', 'angles', expected), path, expected, mat)
    ts = _row(_struct_field(mat, path, 'Hokuyo0', 'ts', expected), path, expected, mat)
    if ranges.ndim != 2 or ranges.shape[0] != angles.size or ranges.shape[1] != ts.size or ts.size == 0 \
            or angles.size < 2:
        raise cc.ConversionError(path, None, expected, got='ranges %s, angles of %d, ts of %d' % (
            'x'.join(map(str, ranges.shape)), angles.size, ts.size))
    steps = np.diff(angles.astype(float))
    if np.ptp(steps) > 1e-6 or steps[0] <= 0:
        raise cc.ConversionError(path, None, 'uniformly increasing Hokuyo angles',
                                 got='steps from %.6g to %.6g rad' % (steps.min(), steps.max()))
    if np.any(np.diff(ts) <= 0):
        raise cc.ConversionError(path, None, 'increasing Hokuyo time stamps',
                                 got='%d steps back or repeated' % int(np.sum(np.diff(ts) <= 0)))
    return ts.astype(float), ranges.T.astype(float), angles.astype(float)


def wheel_odometry(counts, track=DEFAULT_TRACK, metres_per_count=METRES_PER_COUNT):
    """Skid-steer dead reckoning: poses (x, y, theta) after each read, and (ds, dtheta) of each read,
    from per-read counts (4, K) in the order FR FL RR RL."""
    counts = np.asarray(counts, dtype=float)
    right = (counts[0] + counts[2]) / 2.0 * metres_per_count
    left = (counts[1] + counts[3]) / 2.0 * metres_per_count
    ds, dth = cc.diff_drive_steps(left, right, track)
    x, y, th = cc.integrate_arcs(ds, dth)
    return x, y, th, ds, dth


def hokuyo_rep117(ranges):
    """Readings above range_max -> +Inf, below range_min (error codes) or not finite -> NaN."""
    r = np.array(ranges, dtype=float)
    bad = ~np.isfinite(r) | (r < HOKUYO_RANGE_MIN)
    r[r > HOKUYO_RANGE_MAX] = np.inf
    r[bad] = np.nan
    return r


def build_parser():
    p = cc.make_parser('ese650_to_bag', __doc__)
    p.add_argument('directory', help='directory of the run files')
    p.add_argument('run', help='run number N (Encoders<N>.mat, imu<N>.mat)')
    p.add_argument('--encoders', help='encoder file (default DIRECTORY/Encoders<N>.mat)')
    p.add_argument('--imu', help='IMU file (default DIRECTORY/imu<N>.mat; optional)')
    p.add_argument('--hokuyo', help='Hokuyo file (default DIRECTORY/Hokuyo<N>.mat if it exists; optional)')
    p.add_argument('--track', type=cc.positive_float, default=DEFAULT_TRACK,
                   help='effective track width of the skid steering [m] (default %.4f = %.2f x the mean of the '
                        'inner and outer wheel tracks)' % (DEFAULT_TRACK, TRACK_SLIP_FACTOR))
    cc.add_common_arguments(
        p,
        topics=(('--odom-topic', 'odom', 'nav_msgs/Odometry'),
                ('--ticks-topic', 'wheel_ticks', 'sensor_msgs/JointState, cumulative wheel angles'),
                ('--imu-topic', 'imu/data', 'sensor_msgs/Imu'),
                ('--scan-topic', 'scan', 'sensor_msgs/LaserScan')),
        frames=(('--odom-frame', 'odom', 'odometry frame'),
                ('--base-frame', 'base_link', 'robot frame (centre of the wheel base, axle height)'),
                ('--imu-frame', 'base_link', 'IMU frame (axes aligned with base_link; another name gets an '
                 'identity transform on /tf_static)'),
                ('--laser-frame', 'laser', 'Hokuyo frame')))
    p.epilog = ('A record for --limit is an encoder read; IMU and scans are cut at the last one. '
                'Source: the data set\'s platform_config.pdf and README_Encoders.txt.') + '\n' + EXAMPLE
    return p


def _run_file(args, explicit, stem):
    return explicit if explicit else os.path.join(args.directory, '%s%s.mat' % (stem, args.run))


def convert(args, out, bad, summary):
    from rbpf_slam import convert_msgs as m
    enc_path = _run_file(args, args.encoders, 'Encoders')
    ts, counts = load_encoders(enc_path)
    if args.limit is not None:
        ts, counts = ts[:args.limit], counts[:, :args.limit]
    t_end = ts[-1]
    x, y, th, ds, dth = wheel_odometry(counts, track=args.track)
    dt = np.diff(ts, prepend=ts[0])
    safe = np.where(dt > 0, dt, 1.0)
    v, w = np.where(dt > 0, ds / safe, 0.0), np.where(dt > 0, dth / safe, 0.0)
    rad_per_count = 2.0 * math.pi / COUNTS_PER_REV
    wheel_angle = np.cumsum(counts, axis=1) * rad_per_count
    wheel_rate = np.where(dt > 0, counts * rad_per_count / safe, 0.0)
    summary.note('effective track %.4f m; %.1f m driven, final pose (%.2f m, %.2f m, %.1f deg)' % (
        args.track, float(np.sum(np.abs(ds))), x[-1], y[-1], math.degrees(th[-1])))

    imu_path = _run_file(args, args.imu, 'imu')
    imu_ts = imu_vals = None
    if args.imu or os.path.exists(imu_path):
        imu_ts, imu_vals = load_imu(imu_path)
        keep = imu_ts <= t_end if args.limit is not None else slice(None)
        imu_ts, imu_vals = imu_ts[keep], imu_vals[:, keep]
    else:
        summary.note('no IMU file (%s)' % imu_path)

    hok_path = _run_file(args, args.hokuyo, 'Hokuyo')
    scans = None
    if args.hokuyo or os.path.exists(hok_path):
        s_ts, s_ranges, s_angles = load_hokuyo(hok_path)
        if args.limit is not None:
            keep = s_ts <= t_end
            s_ts, s_ranges = s_ts[keep], s_ranges[keep]
        scans = (s_ts, s_ranges, float(s_angles[0]), float(np.mean(np.diff(s_angles))))
        summary.note('Hokuyo: %d scans of %d beams; %d readings above %.0f m written as +Inf, %d below %.1f m as NaN'
                     % (len(s_ts), s_ranges.shape[1], int(np.sum(s_ranges > HOKUYO_RANGE_MAX)), HOKUYO_RANGE_MAX,
                        int(np.sum(s_ranges < HOKUYO_RANGE_MIN)), HOKUYO_RANGE_MIN))
    else:
        summary.note('no Hokuyo file (%s): odometry and IMU only' % hok_path)

    firsts = [ts[0]] + ([imu_ts[0]] if imu_ts is not None and len(imu_ts) else []) + \
        ([scans[0][0]] if scans is not None and len(scans[0]) else [])
    t0 = float(min(firsts))
    n_imu = 0 if imu_ts is None else len(imu_ts)
    out.expect(3 * len(ts) + n_imu + (0 if scans is None else len(scans[0])) + 1)

    def statics():
        tfs = []
        if scans is not None:
            tfs.append(m.transform(t0, args.base_frame, args.laser_frame, LASER_MOUNT[0], LASER_MOUNT[1], 0.0,
                                   z=LASER_MOUNT[2]))
        if imu_ts is not None and args.imu_frame != args.base_frame:
            tfs.append(m.transform(t0, args.base_frame, args.imu_frame, 0.0, 0.0, 0.0))
        if tfs:
            yield t0, '/tf_static', m.tf_message(*tfs), True

    def odometry():
        for i in range(len(ts)):
            t = float(ts[i])
            yield t, args.odom_topic, m.odometry(t, args.odom_frame, args.base_frame, float(x[i]), float(y[i]),
                                                 float(th[i]), float(v[i]), float(w[i])), False
            yield t, '/tf', m.tf_message(m.transform(t, args.odom_frame, args.base_frame, float(x[i]), float(y[i]),
                                                     float(th[i]))), False
            yield t, args.ticks_topic, m.joint_state(t, WHEEL_NAMES, wheel_angle[:, i].tolist(),
                                                     wheel_rate[:, i].tolist()), False

    def imu():
        if imu_ts is None:
            return
        g = m.GRAVITY
        for i in range(len(imu_ts)):
            t = float(imu_ts[i])
            a = imu_vals[:, i]
            yield t, args.imu_topic, m.imu(t, args.imu_frame, (float(a[3]), float(a[4]), float(a[5])),
                                           (float(a[0]) * g, float(a[1]) * g, float(a[2]) * g)), False

    def laser():
        if scans is None:
            return
        s_ts, s_ranges, a0, inc = scans
        for i in range(len(s_ts)):
            t = float(s_ts[i])
            yield t, args.scan_topic, m.laser_scan(t, args.laser_frame, a0, inc, hokuyo_rep117(s_ranges[i]).tolist(),
                                                   HOKUYO_RANGE_MIN, HOKUYO_RANGE_MAX, HOKUYO_SCAN_TIME,
                                                   HOKUYO_SCAN_TIME / HOKUYO_STEPS_PER_TURN), False

    out.write_merged([statics(), odometry(), imu(), laser()])


def main(argv=None):
    return cc.run(build_parser(), convert, argv)
