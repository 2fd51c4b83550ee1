#!/usr/bin/env python3
"""rostest node: the forest simulator's topics carry what a SLAM consumer expects.

Runs beside forest_sim.launch (paper world, straight drive, every sensor on, use_sim_time).
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from nav_msgs.msg import Odometry
from rbpf_slam.msg import TrunkArray
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, LaserScan, PointCloud2
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray


class ForestSimCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.lock = threading.Lock()
        cls.got = {k: [] for k in ('points', 'scan', 'odom', 'imu', 'truth', 'tf', 'clock')}
        cls.latched = {}

        def keep(key, limit=400):
            def cb(msg):
                arrival = rospy.Time.now()
                with cls.lock:
                    if len(cls.got[key]) < limit:
                        cls.got[key].append((arrival, msg))
            return cb

        def latch(key):
            def cb(msg):
                cls.latched[key] = msg
            return cb

        cls.subs = [
            rospy.Subscriber('points', PointCloud2, keep('points', 20), queue_size=5),
            rospy.Subscriber('scan', LaserScan, keep('scan', 50), queue_size=10),
            rospy.Subscriber('odom', Odometry, keep('odom'), queue_size=100),
            rospy.Subscriber('imu/data', Imu, keep('imu'), queue_size=100),
            rospy.Subscriber('ground_truth/odom', Odometry, keep('truth'), queue_size=100),
            rospy.Subscriber('/tf', TFMessage, keep('tf'), queue_size=100),
            rospy.Subscriber('/clock', Clock, keep('clock', 50), queue_size=100),
            rospy.Subscriber('ground_truth/trees', TrunkArray, latch('trees')),
            rospy.Subscriber('ground_truth/tree_markers', MarkerArray, latch('markers')),
            rospy.Subscriber('/tf_static', TFMessage, latch('tf_static')),
        ]
        t0 = time.time()
        while not rospy.is_shutdown() and time.time() - t0 < 60.0:
            with cls.lock:
                ready = all(len(v) >= 10 for v in cls.got.values())
            if ready and len(cls.latched) == 3:
                break
            time.sleep(0.1)

    def test_latched_truth_trees_and_markers(self):
        self.assertIn('trees', self.latched, 'no ground_truth/trees')
        trees = self.latched['trees']
        self.assertEqual(len(trees.trunks), 16)
        self.assertEqual(trees.header.frame_id, 'map')
        # The paper world's first tree list line relative to the start pose (0, 15, 0): within the lean.
        for t in trees.trunks:
            self.assertGreater(t.radius, 0.05)
            self.assertLess(t.radius, 0.3)
        self.assertIn('markers', self.latched, 'no ground_truth/tree_markers')
        self.assertEqual(len(self.latched['markers'].markers), 16)

    def test_point_cloud_layout(self):
        self.assertGreaterEqual(len(self.got['points']), 10)
        _, cloud = self.got['points'][-1]
        self.assertEqual(cloud.header.frame_id, 'velodyne')
        names = [f.name for f in cloud.fields]
        for name in ('x', 'y', 'z', 'intensity', 'ring', 'time'):
            self.assertIn(name, names)
        self.assertGreater(cloud.width * cloud.height, 5000)
        self.assertEqual(len(cloud.data), cloud.width * cloud.height * cloud.point_step)

    def test_scan_follows_rep117(self):
        self.assertGreaterEqual(len(self.got['scan']), 10)
        _, scan = self.got['scan'][-1]
        self.assertEqual(scan.header.frame_id, 'laser')
        finite = [r for r in scan.ranges if math.isfinite(r)]
        self.assertTrue(finite, 'no returns at all in the forest')
        self.assertTrue(all(scan.range_min <= r <= scan.range_max for r in finite))
        self.assertTrue(all(r == float('inf') for r in scan.ranges if not math.isfinite(r)),
                        'no-return beams must be +Inf (REP-117)')

    def test_odometry_is_stamped_with_its_measurement_time_and_arrives_late(self):
        odom = self.got['odom']
        self.assertGreaterEqual(len(odom), 10)
        stamps = [m.header.stamp.to_sec() for _, m in odom]
        self.assertTrue(all(b > a for a, b in zip(stamps, stamps[1:])), 'odometry stamps must increase')
        self.assertEqual(odom[-1][1].header.frame_id, 'odom')
        self.assertEqual(odom[-1][1].child_frame_id, 'base_link')
        # 30 ms latency: received (sim clock) after its stamp by about that much.
        delays = sorted(arrival.to_sec() - m.header.stamp.to_sec() for arrival, m in odom)
        self.assertGreaterEqual(delays[len(delays) // 2], 0.02)
        self.assertLess(delays[len(delays) // 2], 0.1)

    def test_frames_follow_rep105(self):
        pairs = set()
        for _, msg in self.got['tf']:
            for t in msg.transforms:
                pairs.add((t.header.frame_id, t.child_frame_id))
        self.assertIn(('odom', 'base_link'), pairs)
        self.assertNotIn(('map', 'odom'), pairs, 'the simulator must not publish map -> odom (SLAM does)')
        self.assertIn('tf_static', self.latched)
        statics = {(t.header.frame_id, t.child_frame_id): t for t in self.latched['tf_static'].transforms}
        self.assertIn(('base_link', 'velodyne'), statics)
        self.assertAlmostEqual(statics[('base_link', 'velodyne')].transform.translation.z, 1.8)

    def test_truth_moves_and_imu_sees_gravity(self):
        truth = self.got['truth']
        self.assertGreaterEqual(len(truth), 10)
        self.assertEqual(truth[-1][1].header.frame_id, 'map')
        _, imu = self.got['imu'][-1]
        g = math.sqrt(imu.linear_acceleration.x ** 2 + imu.linear_acceleration.y ** 2 +
                      imu.linear_acceleration.z ** 2)
        self.assertAlmostEqual(g, 9.81, delta=0.6)
        self.assertEqual(imu.orientation_covariance[0], -1.0, 'no orientation estimate (REP-145)')


if __name__ == '__main__':
    rospy.init_node('forest_sim_check')
    rostest.rosrun('rbpf_slam', 'forest_sim_check', ForestSimCheck)
