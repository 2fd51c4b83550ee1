#!/usr/bin/env python3
"""rostest node: FastSLAM on the simulator's trunks ends near the ground truth.

Runs beside fastslam_pipeline.test (forest_sim in lockstep -> trunk extraction -> FastSLAM, one manager).
"""
import bisect
import math
import os
import tempfile
import unittest

import rospy
import rostest
from rbpf_slam import evaluate
from std_srvs.srv import Trigger
from sim_run import SimRun


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class FastSlamPipelineCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.sim = SimRun(limit=80.0)
        cls.lock, cls.truth, cls.odom, cls.tf_buffer = cls.sim.lock, cls.sim.truth, cls.sim.odom, cls.sim.tf_buffer

    def test_the_simulator_finished(self):
        self.assertTrue(self.sim.done, 'no sim_done within 80 s wall time')

    def test_map_to_odom_is_on_tf(self):
        self.assertTrue(self.tf_buffer.can_transform('map', 'odom', rospy.Time(0), rospy.Duration(2.0)),
                        'no TF map -> odom')

    def test_landmarks_are_published_once_each(self):
        with self.lock:
            lm = self.sim.landmarks
        self.assertIsNotNone(lm, 'no landmark_array')
        self.assertEqual(lm.header.frame_id, 'map')
        self.assertGreaterEqual(len(lm.trunks), 3)
        ids = [t.id for t in lm.trunks]
        self.assertEqual(len(ids), len(set(ids)))

    @staticmethod
    def position_at(samples, stamp):
        stamps = [s[0] for s in samples]
        i = min(max(bisect.bisect_left(stamps, stamp), 1), len(samples) - 1)
        (s0, x0, y0), (s1, x1, y1) = samples[i - 1][:3], samples[i][:3]
        a = 0.0 if s1 <= s0 else min(1.0, max(0.0, (stamp - s0) / (s1 - s0)))
        return x0 + a * (x1 - x0), y0 + a * (y1 - y0)

    def test_final_pose_is_near_the_truth_and_better_than_odometry(self):
        t = self.tf_buffer.lookup_transform('map', 'base_link', rospy.Time(0), rospy.Duration(2.0))
        stamp = t.header.stamp.to_sec()
        with self.lock:
            truth = list(self.truth)
            odom = list(self.odom)
        self.assertGreater(len(truth), 10, 'no ground truth')
        self.assertGreater(len(odom), 10, 'no odometry')
        tx, ty = self.position_at(truth, stamp)
        ox, oy = self.position_at(odom, stamp)
        ex, ey = t.transform.translation.x, t.transform.translation.y
        error = math.hypot(ex - tx, ey - ty)
        rospy.loginfo('fastslam_pipeline: final position error %.3f m (odometry alone %.3f m) at t=%.2f (estimate '
                      '%.2f %.2f, truth %.2f %.2f, travelled %.1f m, %.1f s wall)', error, math.hypot(ox - tx, oy - ty),
                      stamp, ex, ey, tx, ty, math.hypot(tx, ty), self.sim.wall)
        self.assertGreater(math.hypot(tx, ty), 5.0, 'the robot did not drive')
        self.assertLess(error, 0.5)
        # Odometry drifts about 0.4 m over this drive: the map must have done better.
        self.assertLess(error, math.hypot(ox - tx, oy - ty))

    def test_save_inventory_writes_the_tree_table(self):
        rospy.wait_for_service('fastslam/save_inventory', 5.0)
        path = os.path.join(tempfile.mkdtemp(), 'sub', 'trees.csv')
        rospy.set_param('fastslam/inventory_path', path)
        res = rospy.ServiceProxy('fastslam/save_inventory', Trigger)()
        self.assertTrue(res.success, res.message)
        with open(path) as f:
            lines = f.read().splitlines()
        self.assertEqual(lines[0], 'id,x,y,dbh,sigma_x,sigma_y,sigma_dbh,observations,provisional,cov_xy,first_seen,'
                                   'last_seen')
        self.assertGreaterEqual(len(lines), 4)
        for line in lines[1:]:
            cols = line.split(',')
            self.assertEqual(len(cols), 12)
            self.assertGreater(float(cols[3]), 0.0)
            self.assertIn(cols[8], ('0', '1'))
        # The evaluators' reader takes the inventory as it takes slam_bag's map.csv.
        trees = evaluate.read_landmarks_csv(path)
        self.assertEqual(len(trees['x']), len(lines) - 1)
        self.assertTrue((trees['radius'] > 0.0).all())
        # Seen on this drive: the times of the first and the last sighting are simulated ROS time.
        self.assertTrue((trees['first_seen'] > 0.0).all())
        self.assertTrue((trees['last_seen'] >= trees['first_seen']).all())

    def test_save_map_writes_a_map_in_a_local_frame(self):
        rospy.wait_for_service('fastslam/save_map', 5.0)
        path = os.path.join(tempfile.mkdtemp(), 'forest_map.csv')
        rospy.set_param('fastslam/map_path', path)
        res = rospy.ServiceProxy('fastslam/save_map', Trigger)()
        self.assertTrue(res.success, res.message)
        self.assertIn(path, res.message)
        trees = evaluate.read_landmarks_csv(path)
        self.assertGreaterEqual(len(trees['x']), 3)
        self.assertIsNone(trees['anchor'])  # started without a saved map: a local frame only


if __name__ == '__main__':
    rospy.init_node('fastslam_pipeline_check')
    rostest.rosrun('rbpf_slam', 'fastslam_pipeline', FastSlamPipelineCheck)
