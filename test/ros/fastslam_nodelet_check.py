#!/usr/bin/env python3
"""rostest node: the FastSLAM nodelet's odometry buffering, timeout and time checks on synthetic input."""
import math
import threading
import time
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from rbpf_slam.msg import Trunk, TrunkArray
from rosgraph_msgs.msg import Log

T0 = 1000.0
TREES = [(4.0, 1.0, 0.2), (6.0, -2.0, 0.15), (3.0, -3.0, 0.25), (8.0, 2.5, 0.3)]  # in the odom frame


class FastSlamNodeletCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.poses = []  # (the message, the wall time it came)
        cls.warnings = []
        cls.sub = rospy.Subscriber('pose', PoseWithCovarianceStamped, cls.on_pose, queue_size=50)
        cls.log_sub = rospy.Subscriber('/rosout', Log, cls.on_log, queue_size=100)
        cls.odom_pub = rospy.Publisher('odom', Odometry, queue_size=50)
        cls.trunks_pub = rospy.Publisher('trunks', TrunkArray, queue_size=50)
        cls.static = tf2_ros.StaticTransformBroadcaster()
        t = TransformStamped()
        t.header.stamp = rospy.Time(T0)
        t.header.frame_id = 'base_link'
        t.child_frame_id = 'velodyne'
        t.transform.translation.x = 0.5
        t.transform.translation.z = 1.8
        t.transform.rotation.w = 1.0
        cls.static.sendTransform(t)
        t0 = time.time()
        while time.time() - t0 < 10.0 and (cls.odom_pub.get_num_connections() == 0 or
                                           cls.trunks_pub.get_num_connections() == 0):
            time.sleep(0.05)
        time.sleep(0.5)

    @classmethod
    def on_pose(cls, msg):
        with cls.lock:
            cls.poses.append((msg, time.time()))

    @classmethod
    def on_log(cls, msg):
        if msg.level >= Log.WARN:
            with cls.lock:
                cls.warnings.append(msg.msg)

    def wait_warning(self, text, timeout):
        """True once the node warned with a message holding @p text (within @p timeout seconds)."""
        t0 = time.time()
        while time.time() - t0 < timeout:
            with self.lock:
                if any(text in w for w in self.warnings):
                    return True
            time.sleep(0.02)
        return False

    def odom(self, stamp, x):
        m = Odometry()
        m.header.stamp = rospy.Time(T0 + stamp)
        m.header.frame_id = 'odom'
        m.child_frame_id = 'base_link'
        m.pose.pose.position.x = x
        m.pose.pose.orientation.w = 1.0
        self.odom_pub.publish(m)

    def trunks(self, stamp, robot_x):
        a = TrunkArray()
        a.header.stamp = rospy.Time(T0 + stamp)
        a.header.frame_id = 'velodyne'
        for (x, y, r) in TREES:
            t = Trunk()
            t.center.x = x - robot_x - 0.5
            t.center.y = y
            t.center.z = 0.0
            t.radius = r
            t.radius_variance = 1e-4
            t.range = math.hypot(t.center.x, t.center.y)
            t.bearing = math.atan2(t.center.y, t.center.x)
            t.covariance = [1e-3, 0.0, 0.0, 1e-3]
            t.method = Trunk.METHOD_CIRCLE
            t.id = -1
            a.trunks.append(t)
        self.trunks_pub.publish(a)

    def count(self):
        with self.lock:
            return len(self.poses)

    def wait_count(self, n, timeout):
        t0 = time.time()
        while time.time() - t0 < timeout:
            if self.count() >= n:
                return True
            time.sleep(0.02)
        return False

    def test_sequence(self):
        # Trunks first: they wait until odometry covers their stamp; odometry before it does not release them.
        self.trunks(1.0, 0.0)
        self.odom(0.9, 0.0)
        time.sleep(0.3)  # time the node would take to process them early
        covered = time.time()
        self.odom(1.1, 0.0)
        self.assertTrue(self.wait_count(1, 2.0), 'no pose once odometry covered the trunks')
        with self.lock:
            first, first_came = self.poses[0]
        self.assertGreaterEqual(first_came, covered, 'processed before odometry covered the stamp')
        self.assertEqual(first.header.frame_id, 'map')
        self.assertAlmostEqual(first.header.stamp.to_sec(), T0 + 1.0, places=6)

        # Driving on at 1 m/s along x: the pose follows (interpolated at the trunks' stamps).
        for k in range(3, 13):
            self.odom(k * 0.5 + 0.1, (k * 0.5 + 0.1 - 1.0))
            self.trunks(k * 0.5, k * 0.5 - 1.0)
            self.odom(k * 0.5 + 0.2, (k * 0.5 + 0.2 - 1.0))
        self.assertTrue(self.wait_count(11, 3.0), 'not every array was processed (%d)' % self.count())
        with self.lock:
            last = self.poses[-1][0]
        self.assertAlmostEqual(last.header.stamp.to_sec(), T0 + 6.0, places=6)
        self.assertLess(abs(last.pose.pose.position.x - 5.0), 0.3)
        self.assertLess(abs(last.pose.pose.position.y), 0.3)

        # A late array (0.5 s before the previous one, less than ~time_jump_threshold): dropped with a warning
        # naming it, no pose, no restart.
        n = self.count()
        self.trunks(5.5, 4.5)
        self.assertTrue(self.wait_warning('stamped %.3f: before the previous stamp; dropped' % (T0 + 5.5), 3.0),
                        'the late array was not reported as dropped')
        self.assertEqual(self.count(), n, 'an array older than the previous one was processed')
        with self.lock:
            self.assertFalse(any('restarts' in w for w in self.warnings), self.warnings)

        # Odometry that does not come: processed after the timeout (odom_timeout 1.5 s) with the newest odometry.
        sent = time.time()
        self.trunks(7.0, 5.2)
        self.assertTrue(self.wait_count(n + 1, 5.0), 'not processed after the odometry timeout')
        with self.lock:
            late, came = self.poses[-1]
        self.assertAlmostEqual(late.header.stamp.to_sec(), T0 + 7.0, places=6)
        self.assertGreaterEqual(came - sent, 1.4, 'processed before the odometry timeout')
        self.assertTrue(self.wait_warning('no odometry up to the trunks at %.3f' % (T0 + 7.0), 1.0))

if __name__ == '__main__':
    rospy.init_node('fastslam_nodelet_check')
    rostest.rosrun('rbpf_slam', 'fastslam_nodelet', FastSlamNodeletCheck)
