#!/usr/bin/env python3
"""rostest node: FastSLAM started from a saved map finds the robot in it (fastslam_localize.test).

The saved map's frame is the simulator's default start (0, 15) heading east; this run starts at (25, 20) heading
200 degrees, and the simulator's truth is relative to that start. At the end, map -> base_link must be the truth
carried into the saved map's frame, and the published trees must be the saved ones (their ids).
"""
import csv
import math
import os
import tempfile
import unittest

import rospy
import rostest
from std_srvs.srv import Trigger
from sim_run import SimRun

SAVED_START = (0.0, 15.0, 0.0)
THIS_START = (25.0, 20.0, math.radians(200.0))


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


class FastSlamLocalizeCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.sim = SimRun(limit=80.0)
        cls.lock, cls.truth, cls.odom, cls.tf_buffer = cls.sim.lock, cls.sim.truth, cls.sim.odom, cls.sim.tf_buffer

    def test_the_robot_is_found_in_the_saved_map(self):
        self.assertTrue(self.sim.done, 'no sim_done within 80 s wall time')
        t = self.tf_buffer.lookup_transform('map', 'base_link', rospy.Time(0), rospy.Duration(2.0))
        stamp = t.header.stamp.to_sec()
        with self.lock:
            truth = list(self.truth)
        self.assertGreater(len(truth), 10, 'no ground truth')
        nearest = min(truth, key=lambda s: abs(s[0] - stamp))
        expected = compose(compose(inverse(SAVED_START), THIS_START), nearest[1:])
        got = (t.transform.translation.x, t.transform.translation.y)
        error = math.hypot(got[0] - expected[0], got[1] - expected[1])
        rospy.loginfo('fastslam_localize: map -> base_link (%.2f, %.2f), truth in the saved map (%.2f, %.2f): %.3f m',
                      got[0], got[1], expected[0], expected[1], error)
        self.assertLess(error, 0.3)

    def test_the_saved_trees_are_kept(self):
        with self.lock:
            lm = self.sim.landmarks
        self.assertIsNotNone(lm, 'no landmark_array')
        ids = set(t.id for t in lm.trunks)
        self.assertGreaterEqual(len(ids & set(range(16))), 14, 'the saved trees (ids 0..15) are gone: %s' % sorted(ids))

    def test_save_map_writes_the_change_report(self):
        rospy.wait_for_service('fastslam/save_map', 5.0)
        path = os.path.join(tempfile.mkdtemp(), 'visit2.csv')
        rospy.set_param('fastslam/map_path', path)
        res = rospy.ServiceProxy('fastslam/save_map', Trigger)()
        self.assertTrue(res.success, res.message)
        self.assertIn('changes since', res.message)
        with open(os.path.join(os.path.dirname(path), 'visit2_changes.csv')) as f:
            rows = list(csv.DictReader(f))
        # The stand is the saved one: nothing was felled.
        self.assertEqual([r['id'] for r in rows if r['kind'] == 'felled'], [], rows)


if __name__ == '__main__':
    rospy.init_node('fastslam_localize_check')
    rostest.rosrun('rbpf_slam', 'fastslam_localize', FastSlamLocalizeCheck)
