#!/usr/bin/env python3
"""rostest node: the grid SLAM nodelet on a replayed bag of the simulator's indoor world.

Records a 16 m drive along the south corridor and round the corner with record_scenario (deterministic), replays its sensor
topics (/scan, /tf, /tf_static) with --clock, and checks what the nodelet publishes: the latched map lies on
the world's walls, the final pose is near the truth, map -> odom is on TF, map_metadata matches the map,
and ~save_map writes a map_server map.
"""
import math
import os
import shutil
import subprocess
import tempfile
import threading
import time
import unittest

import numpy as np
import rosbag
import roslib.packages
import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseWithCovarianceStamped
from nav_msgs.msg import MapMetaData, OccupancyGrid
from std_srvs.srv import Trigger

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WORLD = os.path.join(ROOT, 'config', 'worlds', 'indoor.yaml')
SAVED = '/tmp/rbpf_slam_grid_slam_test/map.yaml'


def load_world():
    """The indoor world's occupied cells as world points (the PGM: 0 = occupied), resolution, origin."""
    with open(os.path.join(ROOT, 'config', 'worlds', 'indoor.pgm'), 'rb') as f:
        data = f.read()
    # P5 header: magic, width, height, maxval (comments allowed)
    tokens, pos = [], 0
    while len(tokens) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b'#':
            pos = data.index(b'\n', pos) + 1
            continue
        end = pos
        while not data[end:end + 1].isspace():
            end += 1
        tokens.append(data[pos:end])
        pos = end
    w, h = int(tokens[1]), int(tokens[2])
    img = np.frombuffer(data[pos + 1:pos + 1 + w * h], dtype=np.uint8).reshape(h, w)[::-1]  # row 0 at the bottom
    occ = np.argwhere(img < 50)  # (row, col)
    res, ox, oy = 0.05, -5.0, -2.4  # indoor.yaml
    return np.column_stack([ox + (occ[:, 1] + 0.5) * res, oy + (occ[:, 0] + 0.5) * res])


def yaw_of(q):
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


class GridSlamCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.mkdtemp(prefix='grid_slam_test_')
        wp = os.path.join(cls.tmp, 'corridor.txt')
        with open(wp, 'w') as f:
            f.write('4 0\n8 0\n12.9 0\n12.9 3\n')
        start = os.path.join(cls.tmp, 'start.yaml')
        with open(start, 'w') as f:  # the indoor world's start pose (indoor.yaml) is its origin
            f.write('start: {x: 0.0, y: 0.0, yaw_deg: 0.0}\n')
        cls.bag = os.path.join(cls.tmp, 'indoor.bag')
        tool = roslib.packages.find_node('rbpf_slam', 'record_scenario')[0]
        subprocess.run([tool, '--indoor-map', WORLD, '--config', start, '--drive', wp, '--seed', '4', '--out', cls.bag,
                        '--no-points', '--quiet'], check=True, stdout=subprocess.DEVNULL)
        cls.truth = []
        with rosbag.Bag(cls.bag) as b:
            for _, m, _ in b.read_messages(topics=['/ground_truth/odom']):
                p = m.pose.pose.position
                cls.truth.append((m.header.stamp.to_sec(), p.x, p.y))
        cls.lock = threading.Lock()
        cls.map = None
        cls.metadata = None
        cls.poses = []
        cls.tf_buffer = tf2_ros.Buffer(rospy.Duration(120.0))
        cls.tf_listener = tf2_ros.TransformListener(cls.tf_buffer)

        def on_map(msg):
            with cls.lock:
                cls.map = msg

        def on_metadata(msg):
            with cls.lock:
                cls.metadata = msg

        def on_pose(msg):
            with cls.lock:
                cls.poses.append(msg)

        cls.subs = [rospy.Subscriber('map', OccupancyGrid, on_map, queue_size=1),
                    rospy.Subscriber('map_metadata', MapMetaData, on_metadata, queue_size=1),
                    rospy.Subscriber('pose', PoseWithCovarianceStamped, on_pose, queue_size=1000)]
        rospy.wait_for_service('grid_slam/save_map', timeout=30.0)
        time.sleep(1.0)  # let the subscriptions connect before the bag starts
        # The sensor topics only: the truth stays out of the filter's reach.
        play = subprocess.run(['rosbag', 'play', '--clock', '-q', '--wait-for-subscribers', '-r', str(rospy.get_param('~rate', 3.0)), cls.bag, '--topics', '/scan', '/tf',
                               '/tf_static'], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              universal_newlines=True)
        assert play.returncode == 0, play.stderr
        cls.wait_until_quiet()
        # What the first run left, taken before the bag is played again: the tests read these, in any order.
        with cls.lock:
            cls.first_map, cls.first_metadata, cls.first_poses = cls.map, cls.metadata, list(cls.poses)
        # No timeout: the clock stopped with the bag (sim time), and the transforms came while it played.
        cls.first_map_to_odom = cls.tf_buffer.lookup_transform('map', 'odom', rospy.Time(0))
        cls.first_map_to_base = cls.tf_buffer.lookup_transform('map', 'base_link', rospy.Time(0))
        # The bag played again from its start: time goes backwards, as when a bag loops.
        with cls.lock:
            cls.map = None
        play = subprocess.run(['rosbag', 'play', '--clock', '-q', '-r', '3', '-u', '4', cls.bag, '--topics', '/scan',
                               '/tf', '/tf_static'], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              universal_newlines=True)
        cls.loop_play = play
        cls.wait_until_quiet()
        with cls.lock:
            cls.loop_poses, cls.loop_map = cls.poses[len(cls.first_poses):], cls.map

    @classmethod
    def wait_until_quiet(cls, quiet=1.0, limit=30.0):
        """Returns once the node has published no pose for @p quiet seconds and has published a map (at most
        @p limit seconds): the scans it was sent are processed."""
        deadline = time.time() + limit
        last_count, last_change = -1, time.time()
        while time.time() < deadline:
            with cls.lock:
                count, has_map = len(cls.poses), cls.map is not None
            if count != last_count:
                last_count, last_change = count, time.time()
            elif has_map and time.time() - last_change >= quiet:
                return
            time.sleep(0.05)

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.tmp, ignore_errors=True)

    def test_map_lies_on_the_walls(self):
        m = self.first_map
        self.assertIsNotNone(m, 'no map published')
        self.assertEqual(m.header.frame_id, 'map')
        grid = np.array(m.data, dtype=np.int8).reshape(m.info.height, m.info.width)
        occ = np.argwhere(grid > 65)
        self.assertGreater(len(occ), 200, 'too few occupied cells')
        self.assertGreater(np.count_nonzero(grid == 0) + np.count_nonzero((grid >= 0) & (grid < 35)), 5000)
        res = m.info.resolution
        pts = np.column_stack([m.info.origin.position.x + (occ[:, 1] + 0.5) * res,
                               m.info.origin.position.y + (occ[:, 0] + 0.5) * res])
        walls = load_world()
        # Distance of each occupied map cell to the nearest true wall cell (the map frame is the start frame).
        near = 0
        for p in pts:
            d = np.min(np.hypot(walls[:, 0] - p[0], walls[:, 1] - p[1]))
            near += d < 0.2
        frac = near / float(len(pts))
        self.assertGreater(frac, 0.8, '%.0f %% of %d occupied cells within 0.2 m of a wall' % (100 * frac, len(pts)))

    def test_final_pose_near_the_truth(self):
        poses = self.first_poses
        self.assertGreater(len(poses), 300, 'only %d poses (one per scan expected)' % len(poses))
        last = poses[-1]
        t = last.header.stamp.to_sec()
        truth = min(self.truth, key=lambda s: abs(s[0] - t))
        err = math.hypot(last.pose.pose.position.x - truth[1], last.pose.pose.position.y - truth[2])
        self.assertLess(err, 0.25, 'final pose error %.3f m' % err)
        cov = last.pose.covariance
        self.assertTrue(all(math.isfinite(c) for c in cov))
        self.assertGreaterEqual(cov[0], 0.0)

    def test_map_to_odom_on_tf_and_metadata(self):
        t = self.first_map_to_odom
        self.assertTrue(math.isfinite(t.transform.translation.x))
        # map -> odom -> base_link is where the filter says the robot is (the turn made odometry's heading
        # drift, so map -> odom itself is far from the identity at the end).
        mb = self.first_map_to_base
        m, md, last = self.first_map, self.first_metadata, self.first_poses[-1]
        self.assertLess(math.hypot(mb.transform.translation.x - last.pose.pose.position.x,
                                   mb.transform.translation.y - last.pose.pose.position.y), 0.2)
        self.assertIsNotNone(md)
        self.assertEqual((md.width, md.height), (m.info.width, m.info.height))
        self.assertAlmostEqual(md.resolution, 0.05, places=6)

    def test_save_map_writes_map_server_files(self):
        if os.path.exists(SAVED):
            os.remove(SAVED)
        res = rospy.ServiceProxy('grid_slam/save_map', Trigger)()
        self.assertTrue(res.success, res.message)
        with open(SAVED) as f:
            text = f.read()
        self.assertIn('map.pgm', text)
        self.assertIn('resolution: 0.05', text)
        with open(os.path.join(os.path.dirname(SAVED), 'map.pgm'), 'rb') as f:
            self.assertEqual(f.read(2), b'P5')

    def test_looped_bag_resets_the_filter(self):
        """Time going backwards (the bag played again): the filter starts a new map at the start pose."""
        self.assertEqual(self.loop_play.returncode, 0, self.loop_play.stderr)
        again = self.loop_poses
        self.assertGreater(len(again), 50)
        first = again[0].pose.pose.position
        self.assertLess(math.hypot(first.x, first.y), 0.3, 'the new run starts at the start pose')
        self.assertIsNotNone(self.loop_map, 'the new map is published')

if __name__ == '__main__':
    rospy.init_node('grid_slam_check')
    rostest.rosrun('rbpf_slam', 'grid_slam_nodelet', GridSlamCheck)
