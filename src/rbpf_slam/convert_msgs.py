"""ROS messages the converters write (REP-103 units, REP-105 frames, REP-117 ranges)."""
import math

import rospy
from geometry_msgs.msg import Point, PoseStamped, Quaternion, TransformStamped
from nav_msgs.msg import Odometry, Path
from rbpf_slam.msg import Trunk, TrunkArray
from sensor_msgs.msg import Imu, JointState, LaserScan
from std_msgs.msg import Header
from tf2_msgs.msg import TFMessage

GRAVITY = 9.80665  # [m/s^2] standard gravity, to convert accelerations given in g


def ros_time(t):
    """Seconds (float) as rospy.Time, rounded to the nanosecond."""
    secs = int(math.floor(t))
    nsecs = int(round((t - secs) * 1e9))
    if nsecs >= 1000000000:
        secs += 1
        nsecs -= 1000000000
    return rospy.Time(secs, nsecs)


def header(stamp, frame):
    return Header(stamp=ros_time(stamp), frame_id=frame)


def yaw_quaternion(yaw):
    return Quaternion(0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def odometry(stamp, frame, child, x, y, yaw, v=0.0, w=0.0):
    """nav_msgs/Odometry of a planar pose; twist (v forward [m/s], w yaw rate [rad/s]) in the child frame.
    Covariances are left at zero (unknown): the consumers state their own noise model."""
    msg = Odometry()
    msg.header = header(stamp, frame)
    msg.child_frame_id = child
    msg.pose.pose.position.x = x
    msg.pose.pose.position.y = y
    msg.pose.pose.orientation = yaw_quaternion(yaw)
    msg.twist.twist.linear.x = v
    msg.twist.twist.angular.z = w
    return msg


def transform(stamp, parent, child, x, y, yaw, z=0.0):
    tf = TransformStamped()
    tf.header = header(stamp, parent)
    tf.child_frame_id = child
    tf.transform.translation.x = x
    tf.transform.translation.y = y
    tf.transform.translation.z = z
    tf.transform.rotation = yaw_quaternion(yaw)
    return tf


def tf_message(*transforms):
    return TFMessage(transforms=list(transforms))


def laser_scan(stamp, frame, angle_min, angle_increment, ranges, range_min, range_max, scan_time=0.0,
               time_increment=0.0):
    """sensor_msgs/LaserScan; ``ranges`` a sequence of floats already in REP-117 form."""
    msg = LaserScan()
    msg.header = header(stamp, frame)
    msg.angle_min = angle_min
    msg.angle_increment = angle_increment
    msg.angle_max = angle_min + angle_increment * (len(ranges) - 1)
    msg.time_increment = time_increment
    msg.scan_time = scan_time
    msg.range_min = range_min
    msg.range_max = range_max
    msg.ranges = ranges
    return msg


def imu(stamp, frame, gyro, accel):
    """sensor_msgs/Imu without orientation (orientation_covariance[0] = -1, REP-145): gyro [rad/s],
    accel [m/s^2]; covariances unknown (zero)."""
    msg = Imu()
    msg.header = header(stamp, frame)
    msg.orientation_covariance[0] = -1.0
    msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z = gyro
    msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z = accel
    return msg


def joint_state(stamp, names, positions, velocities=()):
    msg = JointState()
    msg.header = header(stamp, '')
    msg.name = list(names)
    msg.position = list(positions)
    msg.velocity = list(velocities)
    return msg


def path(stamp, frame, stamps, xs, ys, yaws=None):
    """nav_msgs/Path; orientation identity where ``yaws`` is None (positions only)."""
    msg = Path()
    msg.header = header(stamp, frame)
    for i in range(len(stamps)):
        p = PoseStamped()
        p.header = header(stamps[i], frame)
        p.pose.position.x = xs[i]
        p.pose.position.y = ys[i]
        p.pose.orientation = yaw_quaternion(yaws[i]) if yaws is not None else Quaternion(0.0, 0.0, 0.0, 1.0)
        msg.poses.append(p)
    return msg


def trunk(x, y, radius=0.0, radius_variance=0.0, covariance=(0.0, 0.0, 0.0, 0.0), landmark_id=-1, z=0.0,
          range_=None, bearing=None):
    """rbpf_slam/Trunk given directly by a data set (METHOD_GIVEN, score 1)."""
    t = Trunk()
    t.center = Point(x, y, z)
    t.radius = radius
    t.radius_variance = radius_variance
    t.range = math.hypot(x, y) if range_ is None else range_
    t.bearing = math.atan2(y, x) if bearing is None else bearing
    t.covariance = list(covariance)
    t.num_points = 0
    t.num_inliers = 0
    t.score = 1.0
    t.method = Trunk.METHOD_GIVEN
    t.id = int(landmark_id)
    return t


def trunk_array(stamp, frame, trunks, scope=None):
    """``scope``: what the sensor could see, a dict of TrunkArray's min_range, max_range, fov_min, fov_max,
    detection_probability (absent keys: 0, not known)."""
    msg = TrunkArray(header=header(stamp, frame), trunks=list(trunks))
    for key, value in (scope or {}).items():
        setattr(msg, key, float(value))
    return msg
