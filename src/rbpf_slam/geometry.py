"""Small numpy helpers for poses and point clouds read from bags (no ROS imports at module level)."""
import math

import numpy as np

# sensor_msgs/PointField datatypes -> numpy
_POINT_FIELD_TYPES = {
    1: np.int8, 2: np.uint8, 3: np.int16, 4: np.uint16,
    5: np.int32, 6: np.uint32, 7: np.float32, 8: np.float64,
}


def cloud_to_array(msg):
    """A sensor_msgs/PointCloud2 as a numpy structured array (one element per point, named fields)."""
    if msg.is_bigendian:
        raise ValueError('big-endian point clouds are not supported')
    names, formats, offsets = [], [], []
    for f in msg.fields:
        if f.datatype not in _POINT_FIELD_TYPES:
            raise ValueError('point field %r has unknown datatype %d' % (f.name, f.datatype))
        names.append(f.name)
        formats.append((_POINT_FIELD_TYPES[f.datatype], (f.count,)) if f.count > 1 else _POINT_FIELD_TYPES[f.datatype])
        offsets.append(f.offset)
    dtype = np.dtype({'names': names, 'formats': formats, 'offsets': offsets, 'itemsize': msg.point_step})
    n = msg.width * msg.height
    if len(msg.data) < n * msg.point_step:
        raise ValueError('point cloud data is shorter than width x height x point_step')
    return np.frombuffer(msg.data, dtype=dtype, count=n)


def wrap_angle(a):
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(a, dtype=float) + np.pi) % (2 * np.pi) - np.pi


def se2_compose(a, b):
    """a (+) b for planar poses (x, y, theta): b expressed in a's frame, put in a's parent frame."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], float(wrap_angle(a[2] + b[2])))


def se2_between(a, b):
    """The pose of b in a's frame: a^-1 (+) b, for planar poses (x, y, theta); theta in [-pi, pi)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, float(wrap_angle(b[2] - a[2])))


def quaternion_to_matrix(q):
    """Rotation matrices (..., 3, 3) from quaternions (..., 4) given as x, y, z, w (normalised here)."""
    q = np.asarray(q, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    m = np.empty(q.shape[:-1] + (3, 3))
    m[..., 0, 0] = 1 - 2 * (y * y + z * z)
    m[..., 0, 1] = 2 * (x * y - z * w)
    m[..., 0, 2] = 2 * (x * z + y * w)
    m[..., 1, 0] = 2 * (x * y + z * w)
    m[..., 1, 1] = 1 - 2 * (x * x + z * z)
    m[..., 1, 2] = 2 * (y * z - x * w)
    m[..., 2, 0] = 2 * (x * z - y * w)
    m[..., 2, 1] = 2 * (y * z + x * w)
    m[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return m


def yaw_of(q):
    """Yaw [rad] of quaternions (..., 4) given as x, y, z, w."""
    q = np.asarray(q, dtype=float)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def interpolate_poses(times, positions, quaternions, t):
    """Poses at times @p t by linear interpolation of positions and normalised lerp of quaternions.

    times: (N,) increasing; positions (N, 3); quaternions (N, 4) x, y, z, w. Times outside are clamped.
    Returns (positions (M, 3), rotation matrices (M, 3, 3)).
    """
    times = np.asarray(times, dtype=float)
    t = np.clip(np.asarray(t, dtype=float), times[0], times[-1])
    i = np.clip(np.searchsorted(times, t, side='right') - 1, 0, len(times) - 2)
    span = times[i + 1] - times[i]
    a = np.where(span > 0, (t - times[i]) / np.where(span > 0, span, 1.0), 0.0)[:, None]
    p = (1 - a) * positions[i] + a * positions[i + 1]
    q0, q1 = quaternions[i], quaternions[i + 1]
    q1 = np.where(np.sum(q0 * q1, axis=1, keepdims=True) < 0, -q1, q1)
    return p, quaternion_to_matrix((1 - a) * q0 + a * q1)
