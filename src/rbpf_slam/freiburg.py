"""Freiburg "Robot Mapping" course data (``world.dat``, ``sensor_data.dat``) to a rosbag.

* ``sensor_data.dat``: ``ODOMETRY r1 t r2`` (rot1-trans-rot2 odometry: turn r1, drive t, turn r2; m
  and rad), each followed by the ``SENSOR id range bearing`` lines seen after that step. The file has no
  time: step k is stamped ``--start-time + k / --rate`` (default 1 s + k * 0.1 s); the start pose (the
  identity) is published at ``--start-time``.
* Written: ``odom`` (nav_msgs/Odometry) and TF ``odom -> base_link`` per step (the robot starts at the
  origin of the data set's world, so ``odom`` and ``map`` coincide at the start), and per step a
  ``landmarks`` rbpf_slam/TrunkArray in ``base_link`` with the step's observations, even when empty:
  centre (range cos bearing, range sin bearing), range, bearing (a negative range, which the noise
  gives once in the data set, becomes the same point at |range| and bearing + pi), radius 0
  (unknown), the 2 x 2 covariance of the centre from the stated sensor noise (``--range-sigma``
  0.1 m, ``--bearing-sigma`` 0.1 rad: Q = 0.01 I, as given with the data set) through the
  polar-to-Cartesian Jacobian, method METHOD_GIVEN. FastSLAM runs on them directly, without trunk extraction.
* Each array states the sensor's scope (TrunkArray min_range .. max_range, all round): the data set does not
  state the sensor's range, so ``--max-range`` defaults to the largest range the file holds less two range sigmas (a
  landmark at the sensor's limit is reported up to about that much further), to 0.1 m.
* ``id`` is -1 (unknown) unless ``--keep-ids``: the data set gives each observation the true
  landmark's id, i.e. the true data association, which is ground truth and must not reach a filter
  that estimates. ``--keep-ids`` gives the filter the known correspondences (SLAM with the
  association given); say so beside any figure made with it.
* ``world.dat`` (``id x y``): the true landmarks on ``ground_truth/landmarks`` (TrunkArray in ``map``,
  with their ids, latched).
"""
import math
import os

import numpy as np

from rbpf_slam import convert_common as cc

RANGE_SIGMA = 0.1    # [m]
BEARING_SIGMA = 0.1  # [rad]

EXAMPLE = """
Example:
  freiburg_to_bag $RBPF_SLAM_DATA/freiburg_course -o freiburg.bag
  rosbag play --clock freiburg.bag    # /odom, /tf, /landmarks, /ground_truth/landmarks
"""


class Step:
    __slots__ = ('line', 'r1', 't', 'r2', 'observations')

    def __init__(self, line, r1, t, r2):
        self.line, self.r1, self.t, self.r2 = line, r1, t, r2
        self.observations = []  # (id, range, bearing)


def read_sensor_data(path, bad=None, limit=None):
    """Odometry steps with their observations. ``limit``: the first N steps. SENSOR lines before the
    first ODOMETRY line belong to the start pose (returned as the observations of step None)."""
    bad = bad or cc.BadLines()
    steps = []
    initial = []
    n_lines = 0
    for line, tokens in cc.read_tokens(path):
        n_lines += 1
        try:
            if tokens[0] == 'ODOMETRY':
                if limit is not None and len(steps) >= limit:
                    break
                cc.require_fields(tokens, 4, path, line, 'ODOMETRY r1 t r2')
                v = cc.parse_floats(tokens[1:4], path, line, 'numbers as r1 t r2')
                steps.append(Step(line, v[0], v[1], v[2]))
            elif tokens[0] == 'SENSOR':
                cc.require_fields(tokens, 4, path, line, 'SENSOR id range bearing')
                i = cc.parse_ints(tokens[1:2], path, line, 'an integer landmark id')[0]
                v = cc.parse_floats(tokens[2:4], path, line, 'numbers as range bearing')
                (steps[-1].observations if steps else initial).append((int(i), v[0], v[1]))
            else:
                raise cc.ConversionError(path, line, "a line starting with 'ODOMETRY' or 'SENSOR'",
                                         got=cc.quote(tokens[0]))
        except cc.ConversionError as e:
            bad(e)
    if n_lines == 0:
        raise cc.ConversionError(path, None, '"ODOMETRY r1 t r2" and "SENSOR id range bearing" lines',
                                 got='an empty file')
    if not steps:
        raise cc.ConversionError(path, None, 'at least one ODOMETRY line', got='none')
    return steps, initial


def read_world(path, bad=None):
    """True landmarks: (ids, xy (N, 2))."""
    bad = bad or cc.BadLines()
    ids, xy = [], []
    for line, tokens in cc.read_tokens(path):
        try:
            cc.require_fields(tokens, 3, path, line, 'id x y')
            ids.append(int(cc.parse_ints(tokens[:1], path, line, 'an integer landmark id')[0]))
            xy.append(cc.parse_floats(tokens[1:3], path, line, 'numbers as x y'))
        except cc.ConversionError as e:
            bad(e)
    if not ids:
        raise cc.ConversionError(path, None, 'landmark lines "id x y"', got='an empty file')
    return np.array(ids), np.array(xy).reshape(-1, 2)


def integrate_odometry(steps, pose0=(0.0, 0.0, 0.0)):
    """Poses (x, y, theta arrays) after each rot1-trans-rot2 step."""
    x, y, th = pose0
    out = np.empty((len(steps), 3))
    for k, s in enumerate(steps):
        x += s.t * math.cos(th + s.r1)
        y += s.t * math.sin(th + s.r1)
        th = float(cc.wrap_angle(th + s.r1 + s.r2))
        out[k] = (x, y, th)
    return out[:, 0], out[:, 1], out[:, 2]


def normalise_observation(r, bearing):
    """(range, bearing) with range >= 0: a negative range (noise on a landmark the robot stands on) is
    the same point at the opposite bearing. Bearing wrapped to [-pi, pi)."""
    if r < 0.0:
        return -r, float(cc.wrap_angle(bearing + math.pi))
    return r, float(cc.wrap_angle(bearing))


def observation_covariance(r, bearing, range_sigma=RANGE_SIGMA, bearing_sigma=BEARING_SIGMA):
    """Row-major 2 x 2 covariance of (r cos b, r sin b) from independent range and bearing noise."""
    return cc.polar_covariance(r, bearing, range_sigma, bearing_sigma)


def build_parser():
    p = cc.make_parser('freiburg_to_bag', __doc__)
    p.add_argument('directory', help='directory with world.dat and sensor_data.dat')
    p.add_argument('--sensor-data', help='default DIRECTORY/sensor_data.dat')
    p.add_argument('--world', help='default DIRECTORY/world.dat (optional)')
    p.add_argument('--rate', type=cc.positive_float, default=10.0, help='steps per second (default 10)')
    p.add_argument('--start-time', type=float, default=1.0, help='stamp of the start pose [s] (default 1)')
    p.add_argument('--range-sigma', type=cc.positive_float, default=RANGE_SIGMA,
                   help='range noise [m] (default %(default)s)')
    p.add_argument('--bearing-sigma', type=cc.positive_float, default=BEARING_SIGMA,
                   help='bearing noise [rad] (default %(default)s)')
    p.add_argument('--max-range', type=cc.positive_float, default=None,
                   help="the sensor's range [m], stated in every array (default: the file's largest range less "
                        "two range sigmas, to 0.1 m)")
    p.add_argument('--keep-ids', action='store_true',
                   help='keep the given landmark ids in the observations (true data association: ground truth)')
    cc.add_common_arguments(
        p,
        topics=(('--odom-topic', 'odom', 'nav_msgs/Odometry'),
                ('--landmarks-topic', 'landmarks', 'rbpf_slam/TrunkArray, the observations of each step'),
                ('--truth-landmarks-topic', 'ground_truth/landmarks', 'rbpf_slam/TrunkArray, world.dat')),
        frames=(('--odom-frame', 'odom', 'odometry frame'),
                ('--base-frame', 'base_link', 'robot frame, also the frame of the observations'),
                ('--map-frame', 'map', 'frame of the true landmarks')))
    p.epilog = 'A record for --limit is an odometry step.' + '\n' + EXAMPLE
    return p


def convert(args, out, bad, summary):
    from rbpf_slam import convert_msgs as m
    data_path = args.sensor_data or os.path.join(args.directory, 'sensor_data.dat')
    world_path = args.world or os.path.join(args.directory, 'world.dat')
    steps, initial = read_sensor_data(data_path, bad, args.limit)
    x, y, th = integrate_odometry(steps)
    dt = 1.0 / args.rate
    stamps = args.start_time + dt * np.arange(len(steps) + 1)
    world = read_world(world_path, bad) if args.world or os.path.exists(world_path) else None
    n_obs = sum(len(s.observations) for s in steps) + len(initial)
    summary.note('%d steps, %d observations; ids %s' % (
        len(steps), n_obs, 'kept (--keep-ids: true data association)' if args.keep_ids else
        'set to -1 (the given ids are the true association: use --keep-ids for the known-correspondence case)'))
    summary.note('observation covariance from range sigma %.3g m, bearing sigma %.3g rad' % (
        args.range_sigma, args.bearing_sigma))
    negative = [(s.line, r) for s in steps for _, r, _ in s.observations if r < 0.0]
    if negative:
        summary.note('%d observation(s) with a negative range (e.g. %.4f m after the step of line %d): written as '
                     'the same point, at range |r| and bearing + pi' % (len(negative), negative[0][1], negative[0][0]))
    if world is None:
        summary.note('no world file (%s): no ground-truth landmarks' % world_path)
    out.expect(3 * (len(steps) + 1) + (world is not None))
    ranges = [abs(r) for s in steps for _, r, _ in s.observations] + [abs(r) for _, r, _ in initial]
    max_range = args.max_range or (round((max(ranges) - 2.0 * args.range_sigma) * 10.0) / 10.0 if ranges else 0.0)
    scope = {'min_range': 0.0, 'max_range': max_range, 'fov_min': -math.pi, 'fov_max': math.pi}
    summary.note('sensor scope stated in every array: 0-%.1f m all round%s' % (
        max_range, '' if args.max_range else " (the file's largest range less two range sigmas; --max-range sets "
                                             "it)"))

    def trunks_of(observations):
        trunks = []
        for i, r, b in observations:
            r, b = normalise_observation(r, b)
            trunks.append(m.trunk(r * math.cos(b), r * math.sin(b), range_=r, bearing=b,
                                  covariance=observation_covariance(r, b, args.range_sigma, args.bearing_sigma),
                                  landmark_id=i if args.keep_ids else -1))
        return trunks

    def statics():
        if world is not None:
            t0 = float(stamps[0])
            truth = [m.trunk(float(px), float(py), landmark_id=int(i)) for i, (px, py) in zip(*world)]
            yield t0, args.truth_landmarks_topic, m.trunk_array(t0, args.map_frame, truth), True

    def timeline():
        poses = [(0.0, 0.0, 0.0, 0.0, 0.0, initial)]
        for k, s in enumerate(steps):
            poses.append((x[k], y[k], th[k], s.t / dt, (s.r1 + s.r2) / dt, s.observations))
        for k, (px, py, pth, v, w, obs) in enumerate(poses):
            t = float(stamps[k])
            yield t, args.odom_topic, m.odometry(t, args.odom_frame, args.base_frame, float(px), float(py),
                                                 float(pth), float(v), float(w)), False
            yield t, '/tf', m.tf_message(m.transform(t, args.odom_frame, args.base_frame, float(px), float(py),
                                                     float(pth))), False
            yield t, args.landmarks_topic, m.trunk_array(t, args.base_frame, trunks_of(obs), scope), False

    out.write_merged([statics(), timeline()])


def main(argv=None):
    return cc.run(build_parser(), convert, argv)
