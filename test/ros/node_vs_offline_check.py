#!/usr/bin/env python3
"""rostest node: the nodelets and the bag runner run one pipeline per filter.

Beside node_vs_offline.test (trunk extraction + FastSLAM and grid SLAM in one manager, simulated time): records a
short simulated forest drive (3D lidar) and a short indoor drive (2D scanner), runs slam_bag on each, plays each
bag into the nodes with rosbag play --clock, and compares the nodes' path (the estimate at every update) with
slam_bag's estimate.tum: the same number of poses, the same stamps, the same positions within TOLERANCE (FastSLAM)
and GRID_TOLERANCE (grid SLAM in its default mode, whether TF comes with the scans, after them or before them, and
while the node is behind the scans).
"""
import json
import math
import os
import shutil
import subprocess
import tempfile
import threading
import time
import unittest

import rosbag
import rospy
import rostest
from nav_msgs.msg import Path
from std_srvs.srv import Trigger

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOLERANCE = 1e-3  # [m], [rad]: the same code on the same data
# [m], [rad]: the node takes /tf's odometry transforms as slam_bag takes /odom's messages (the same values and
# stamps in a recorded bag); only the printing of estimate.tum rounds
GRID_TOLERANCE = 1e-6
TF_SHIFT = 0.3  # [s] TF played this much after (or before) the scans; within the node's ~odom_timeout (0.5 s)


def read_tum(path):
    rows = []
    with open(path) as f:
        for line in f:
            v = [float(x) for x in line.split()]
            rows.append((v[0], v[1], v[2], 2.0 * math.atan2(v[6], v[7])))
    return rows


def path_rows(msg):
    return [(p.header.stamp.to_sec(), p.pose.position.x, p.pose.position.y,
             2.0 * math.atan2(p.pose.orientation.z, p.pose.orientation.w)) for p in msg.poses]


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


class NodeVsOffline(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.mkdtemp(prefix='rbpf_nvo_')
        cls.lock = threading.Lock()
        cls.paths = {}

        def keep(name):
            def on_path(msg):
                with cls.lock:
                    cls.paths[name] = msg
            return on_path
        cls.subs = [rospy.Subscriber('fastslam/path', Path, keep('fastslam'), queue_size=5),
                    rospy.Subscriber('grid_slam/path', Path, keep('grid'), queue_size=5)]

    @classmethod
    def tearDownClass(cls):
        shutil.rmtree(cls.dir, ignore_errors=True)

    def record(self, name, world_args, waypoints):
        wp = os.path.join(self.dir, name + '.txt')
        with open(wp, 'w') as f:
            f.write(waypoints)
        bag = os.path.join(self.dir, name + '.bag')
        subprocess.run(['rosrun', 'rbpf_slam', 'record_scenario'] + world_args +
                       ['--drive', wp, '--seed', '1', '--out', bag, '--quiet'], check=True,
                       stdout=subprocess.DEVNULL)
        return bag

    def offline(self, bag, args):
        out = os.path.join(self.dir, os.path.basename(bag) + '.out')
        subprocess.run(['rosrun', 'rbpf_slam', 'slam_bag', '--bag', bag, '--seed', '3', '--out', out, '--quiet'] + args,
                       check=True)
        return read_tum(os.path.join(out, 'estimate.tum'))

    def retimed(self, bag, shift):
        """The bag with /tf played @p shift seconds later (earlier when negative): stamps unchanged."""
        out = bag[:-4] + '_tf%+.1f.bag' % shift
        with rosbag.Bag(bag) as src, rosbag.Bag(out, 'w') as dst:
            for topic, msg, t in src.read_messages():
                if topic == '/tf':
                    t = t + rospy.Duration(shift)
                dst.write(topic, msg, t)
        return out

    def play(self, bag, topics, name, expected, patience=20.0):
        with self.lock:
            self.paths.pop(name, None)
        # Every message must reach the nodes, the first ones too: wait until each topic has its subscriber, and
        # give each connection a second to be made before the first message is published.
        subprocess.run(['rosbag', 'play', '--clock', '-q', '-r', '1', '--wait-for-subscribers', '-d', '1', bag,
                        '--topics'] + topics, check=True, stdout=subprocess.DEVNULL)
        deadline = time.time() + patience
        while time.time() < deadline:
            with self.lock:
                msg = self.paths.get(name)
            if msg is not None and len(msg.poses) >= expected:
                break
            time.sleep(0.2)
        time.sleep(1.0)  # a straggler would show as an extra pose
        with self.lock:
            msg = self.paths.get(name)
        self.assertIsNotNone(msg, 'no path from the %s node' % name)
        return path_rows(msg)

    def compare(self, name, node, offline, tolerance=TOLERANCE):
        self.assertGreater(len(offline), 20)
        if len(node) != len(offline):
            node_stamps = set(round(r[0], 6) for r in node)
            offline_stamps = set(round(r[0], 6) for r in offline)
            self.fail('%s: %d poses from the node, %d offline; only offline: %s; only the node: %s' %
                      (name, len(node), len(offline), sorted(offline_stamps - node_stamps)[:5],
                       sorted(node_stamps - offline_stamps)[:5]))
        worst = 0.0
        for a, b in zip(node, offline):
            self.assertAlmostEqual(a[0], b[0], delta=1e-6, msg='%s: stamps differ' % name)
            worst = max(worst, math.hypot(a[1] - b[1], a[2] - b[2]), abs(wrap(a[3] - b[3])))
        rospy.loginfo('%s: %d poses, node vs slam_bag at most %.2e m / rad apart', name, len(node), worst)
        self.assertLess(worst, tolerance, '%s: node and slam_bag differ by %.3g' % (name, worst))

    def test_fastslam_node_runs_the_offline_pipeline(self):
        bag = self.record('forest', ['--world', os.path.join(ROOT, 'config', 'worlds', 'paper_forest.yaml')],
                          '0 0\n8 0\n')
        offline_map = os.path.join(self.dir, 'offline_map.csv')
        offline = self.offline(bag, ['--filter', 'fastslam', '--extraction-config',
                                     os.path.join(ROOT, 'config', 'trunk_extraction.yaml'),
                                     '--config', os.path.join(ROOT, 'config', 'fastslam_advanced.yaml'),
                                     '--config', os.path.join(ROOT, 'config', 'fastslam.yaml'),
                                     '--save-map', offline_map])
        node = self.play(bag, ['/points', '/odom', '/tf', '/tf_static'], 'fastslam', len(offline))
        self.compare('fastslam', node, offline)
        # The node's run folder (~save_run) holds what slam_bag --out writes: the same estimate, the same files.
        folder = os.path.join(self.dir, 'node_run')
        rospy.set_param('fastslam/run_folder', folder)
        rospy.wait_for_service('fastslam/save_run', timeout=10.0)
        reply = rospy.ServiceProxy('fastslam/save_run', Trigger)()
        self.assertTrue(reply.success, reply.message)
        for name in ('estimate.tum', 'odometry.tum', 'estimate_best_history.tum', 'updates.csv', 'map.csv',
                     'timing.json', 'health.txt', 'loops.csv'):
            self.assertTrue(os.path.isfile(os.path.join(folder, name)), name)
        # One writer: the same files as slam_bag's folder, the smoothed run's among them when it has one.
        offline_folder = os.path.join(self.dir, os.path.basename(bag) + '.out')
        self.assertEqual(sorted(os.listdir(folder)), sorted(os.listdir(offline_folder)))
        self.compare('fastslam run folder', read_tum(os.path.join(folder, 'estimate.tum')), offline)
        # ~save_map writes the map slam_bag --save-map writes: the same trees and the same viewpoints.
        node_map = os.path.join(self.dir, 'node_map.csv')
        rospy.set_param('fastslam/map_path', node_map)
        reply = rospy.ServiceProxy('fastslam/save_map', Trigger)()
        self.assertTrue(reply.success, reply.message)
        self.compare_maps(node_map, offline_map)

    def compare_maps(self, node_path, offline_path):
        def read(path):
            comments, trees = [], {}
            with open(path) as f:
                for line in f:
                    if line.startswith('#'):
                        comments.append(line.split(':')[0])
                    elif line.strip() and not line.startswith('id,'):
                        v = line.strip().split(',')
                        trees[int(v[0])] = (float(v[1]), float(v[2]), float(v[3]), int(v[7]), v[8])
            return comments, trees
        node_comments, node_trees = read(node_path)
        offline_comments, offline_trees = read(offline_path)
        self.assertGreater(len(offline_trees), 3)
        self.assertEqual(node_comments, offline_comments, 'the anchor and viewpoint lines differ')
        self.assertEqual(sorted(node_trees), sorted(offline_trees), 'the maps hold different trees')
        for i, a in node_trees.items():
            b = offline_trees[i]
            self.assertLess(max(abs(a[0] - b[0]), abs(a[1] - b[1]), abs(a[2] - b[2])), TOLERANCE, (i, a, b))
            self.assertEqual(a[3:], b[3:], (i, a, b))

    def test_grid_node_runs_the_offline_pipeline(self):
        bag = self.record('indoor', ['--indoor-map', os.path.join(ROOT, 'config', 'worlds', 'indoor.yaml')],
                          '3 0\n6 0\n7 1\n')
        # slam_bag with the node's configuration: the shipped files.
        offline = self.offline(bag, ['--filter', 'grid',
                                     '--config', os.path.join(ROOT, 'config', 'grid_slam_advanced.yaml'),
                                     '--config', os.path.join(ROOT, 'config', 'grid_slam.yaml')])
        with open(os.path.join(self.dir, 'indoor.bag.out', 'timing.json')) as f:
            timing = json.load(f)
        self.assertEqual(timing['updates'], timing['sweeps'], timing)  # the default: every scan
        self.assertEqual(len(offline), timing['sweeps'])
        # As recorded at the scans' rate: the filter falls seconds behind (1081 beams at 40 Hz, every scan) and
        # works through its inbox; then TF after the scans and TF before them. Each play restarts the node's map.
        # A slow machine (a sanitizer build) takes longer: the node is given a minute after each play.
        for shift in (0.0, TF_SHIFT, -TF_SHIFT):
            played = bag if shift == 0.0 else self.retimed(bag, shift)
            node = self.play(played, ['/scan', '/odom', '/tf', '/tf_static'], 'grid', len(offline), patience=60.0)
            self.compare('grid, TF %+.1f s' % shift, node, offline, GRID_TOLERANCE)


if __name__ == '__main__':
    rospy.init_node('node_vs_offline_check')
    rostest.rosrun('rbpf_slam', 'node_vs_offline', NodeVsOffline)
