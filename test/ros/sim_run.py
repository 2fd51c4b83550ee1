"""What a simulated run published, for the rostest checks: gathered until the simulator says sim_done."""
import math
import threading
import time

import rospy
import tf2_ros
from nav_msgs.msg import Odometry
from rbpf_slam.msg import TrunkArray
from std_msgs.msg import Bool


class SimRun(object):
    """Subscribes to the truth (ground_truth/odom: stamp, x, y, yaw), the wheel odometry (odom: stamp, x, y), the
    filter's landmark_array (the last one) and sim_done, keeps a TF buffer, and waits until sim_done or @limit
    seconds of wall time, then one more second (the last arrays: their odometry may wait)."""

    def __init__(self, limit=80.0):
        self.lock = threading.Lock()
        self.truth = []
        self.odom = []
        self.landmarks = None
        self.done = False
        self.tf_buffer = tf2_ros.Buffer(rospy.Duration(60.0))
        self.tf_listener = tf2_ros.TransformListener(self.tf_buffer)
        self.subs = [rospy.Subscriber('ground_truth/odom', Odometry, self._on_truth, queue_size=200),
                     rospy.Subscriber('odom', Odometry, self._on_odom, queue_size=200),
                     rospy.Subscriber('landmark_array', TrunkArray, self._on_landmarks, queue_size=2),
                     rospy.Subscriber('sim_done', Bool, self._on_done)]
        t0 = time.time()
        while not rospy.is_shutdown() and not self.done and time.time() - t0 < limit:
            time.sleep(0.1)
        self.wall = time.time() - t0
        time.sleep(1.0)

    def _on_truth(self, msg):
        p = msg.pose.pose
        yaw = 2.0 * math.atan2(p.orientation.z, p.orientation.w)
        with self.lock:
            self.truth.append((msg.header.stamp.to_sec(), p.position.x, p.position.y, yaw))

    def _on_odom(self, msg):
        p = msg.pose.pose.position
        with self.lock:
            self.odom.append((msg.header.stamp.to_sec(), p.x, p.y))

    def _on_landmarks(self, msg):
        with self.lock:
            self.landmarks = msg

    def _on_done(self, msg):
        self.done = self.done or msg.data
