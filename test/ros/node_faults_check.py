#!/usr/bin/env python3
"""rostest node: every node refuses a bad configuration and survives bad time.

- An invalid value (wrong type, out of range, a bounded particle count exceeded) makes a node exit non-zero
  with the key named, rather than run on defaults it was not given; in a nodelet manager, the load fails and
  the manager stays up.
- A misspelt key is warned by name.
- Grid SLAM drops a late scan, one seconds back and a future-stamped one without restarting the map, and restarts
  (logged) when time really jumps back (a looped bag: several messages agree); FastSLAM keeps its map through late,
  unreadable, oversized and malformed messages, restarts on a loop instead of freezing and saves the map before it.
- Two SLAM nodelets in one manager: the second names the first as the owner of map -> odom.
"""
import math
import os
import signal
import subprocess
import tempfile
import threading
import time
import unittest

import rospy
import rostest
import tf2_ros
from geometry_msgs.msg import PoseWithCovarianceStamped, TransformStamped
from nav_msgs.msg import Odometry
from rbpf_slam.msg import Trunk, TrunkArray
from sensor_msgs.msg import LaserScan
from tf2_msgs.msg import TFMessage

TIMEOUT = 30.0


_MOUNTS = []


def send_mount(parent, child):
    """Adds parent -> child (identity) to /tf_static: one latched message holds every mount sent so far."""
    global _STATIC
    if not _MOUNTS:
        _STATIC = tf2_ros.StaticTransformBroadcaster()
    mount = TransformStamped()
    mount.header.stamp = rospy.Time.now()
    mount.header.frame_id = parent
    mount.child_frame_id = child
    mount.transform.rotation.w = 1.0
    _MOUNTS.append(mount)
    _STATIC.sendTransform(_MOUNTS)


def start(node, name, params, log):
    """rosrun rbpf_slam NODE under __name:=NAME with private parameters, output to the file LOG."""
    args = ['rosrun', 'rbpf_slam', node, '__name:=' + name] + ['_%s:=%s' % kv for kv in params]
    return subprocess.Popen(args, stdout=log, stderr=subprocess.STDOUT, universal_newlines=True)


MALFORMED_MAP = os.path.join(tempfile.mkdtemp(), 'forest_map_bad.csv')
with open(MALFORMED_MAP, 'w') as _f:
    _f.write('id,x,y,dbh\n1,2,nan,0.3\n')
ABSURD_MAP = os.path.join(tempfile.mkdtemp(), 'forest_map_absurd.csv')
with open(ABSURD_MAP, 'w') as _f:
    _f.write('id,x,y,dbh\n1,2,3,0.3\n2,1e308,3,0.3\n')
BIG_MAP = os.path.join(tempfile.mkdtemp(), 'forest_map_big.csv')
with open(BIG_MAP, 'w') as _f:
    _f.write('id,x,y,dbh\n' + ''.join('%d,%d,%d,0.3\n' % (i, i % 100, i // 100) for i in range(5)))


def rss_mb(pid):
    """Resident memory of a process [MB] (rosrun execs the node: its pid is the node's)."""
    with open('/proc/%d/status' % pid) as f:
        for line in f:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    return float('nan')


class ConfigFaults(object):
    """Invalid values, misspelt keys, a refused load."""

    def run_to_exit(self, node, params, timeout=TIMEOUT):
        name = 'bad_%s_%d' % (node, int(time.time() * 1000) % 100000)
        with tempfile.TemporaryFile('w+') as log:
            proc = start(node, name, params, log)
            try:
                code = proc.wait(timeout)
            except subprocess.TimeoutExpired:
                proc.send_signal(signal.SIGINT)
                proc.wait(10)
                code = None
            log.seek(0)
            out = log.read()
        for key, _ in params:
            rospy.delete_param('/%s/%s' % (name, key)) if rospy.has_param('/%s/%s' % (name, key)) else None
        return code, out

    def test_invalid_values_stop_the_node_with_the_key_named(self):
        cases = [
            ('grid_slam', [('mode', 'rbpf'), ('particles', '0')], 'particles'),
            ('grid_slam', [('particles', '10000000')], 'particles must be in 1..5000'),
            ('grid_slam', [('linear_update', '-1.0')], 'linear_update'),
            ('grid_slam', [('time_jump_threshold', '0.0')], 'time_jump_threshold'),
            ('fastslam', [('particles', 'many')], 'particles'),
            ('fastslam', [('odom_timeout', '-1.0')], 'odom_timeout'),
            ('fastslam', [('max_path_poses', '0')], 'max_path_poses'),
            ('fastslam', [('map_file', '/nonexistent/forest_map.csv')], 'map_file: /nonexistent/forest_map.csv'),
            ('fastslam', [('map_file', MALFORMED_MAP)], 'forest_map_bad.csv:2: expected a finite number for y'),
            ('fastslam', [('map_file', ABSURD_MAP)], 'forest_map_absurd.csv:3: expected |x|, |y| <= 100000 m'),
            ('fastslam', [('map_file', BIG_MAP), ('max_landmarks', '3')], 'forest_map_big.csv:5: more than 3 trees'),
            ('fastslam', [('particles', '30.5')], 'particles must be an integer'),
            ('fastslam', [('gps/max_sigma', '-5.0')], 'gps/max_sigma must be a finite number > 0'),
            ('trunk_extraction', [('min_height', 'abc')], 'min_height'),
            ('noise_relay', [('linear_sigma_abs', '-1.0')], 'linear_sigma_abs'),
            ('path_follower', [('speed', '0.0')], 'speed'),
        ]
        for node, params, key in cases:
            code, out = self.run_to_exit(node, params)
            self.assertIsNotNone(code, '%s %s kept running on an invalid value:\n%s' % (node, params, out))
            self.assertNotEqual(code, 0, '%s %s exited 0:\n%s' % (node, params, out))
            self.assertIn(key, out, '%s %s: the message must name %s:\n%s' % (node, params, key, out))
            self.assertNotIn('Segmentation', out)

    def test_misspelt_keys_are_warned_by_name(self):
        name = 'typo_grid_slam'
        with tempfile.TemporaryFile('w+') as log:
            proc = start('grid_slam', name, [('partciles', '5'), ('particles', '3')], log)
            deadline = time.time() + TIMEOUT
            out = ''
            while time.time() < deadline and 'partciles' not in out:
                time.sleep(0.2)
                log.seek(0)
                out = log.read()
            proc.send_signal(signal.SIGINT)
            proc.wait(10)
        self.assertIn('partciles', out, 'a misspelt key must be named:\n' + out)
        self.assertIn('not one of this node', out)
        self.assertNotIn('parameter /%s/particles is not' % name, out, 'a real key was warned:\n' + out)

    def test_a_refused_load_leaves_the_manager_up(self):
        with tempfile.TemporaryFile('w+') as log:
            manager = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'manager', '__name:=fault_manager'],
                                       stdout=log, stderr=subprocess.STDOUT)
            try:
                time.sleep(2.0)
                load = subprocess.run(['rosrun', 'nodelet', 'nodelet', 'load', 'rbpf_slam/GridSlamNodelet',
                                       'fault_manager', '__name:=refused_grid', '_particles:=0'],
                                      stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True,
                                      timeout=TIMEOUT)
                self.assertNotEqual(load.returncode, 0, 'nodelet load of an invalid configuration succeeded')
                time.sleep(1.0)
                self.assertIsNone(manager.poll(), 'the manager died')
                # And it still loads a good nodelet.
                good = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'load', 'rbpf_slam/NoiseRelayNodelet',
                                         'fault_manager', '__name:=good_relay'], stdout=subprocess.DEVNULL,
                                        stderr=subprocess.DEVNULL)
                deadline = time.time() + TIMEOUT
                while time.time() < deadline and '/cmd_vel_noisy' not in [t for t, _ in rospy.get_published_topics()]:
                    time.sleep(0.2)
                self.assertIn('/cmd_vel_noisy', [t for t, _ in rospy.get_published_topics()])
                self.assertIsNone(manager.poll(), 'the manager died')
                good.send_signal(signal.SIGINT)
                good.wait(10)
            finally:
                manager.send_signal(signal.SIGINT)
                manager.wait(10)
            log.seek(0)
            self.assertIn('particles', log.read())


class TimeFaults(object):
    """Grid SLAM and FastSLAM fed with wall-clock stamps, with late, future and looped messages among them."""

    def scan(self, stamp, frame='fault_laser'):
        msg = LaserScan()
        msg.header.stamp = stamp
        msg.header.frame_id = frame
        msg.angle_min, msg.angle_increment = -1.5, 0.01
        msg.range_min, msg.range_max = 0.1, 30.0
        # A room: walls 4 m ahead and 3 m to each side.
        msg.ranges = [min(4.0 / max(math.cos(msg.angle_min + i * msg.angle_increment), 1e-3),
                          3.0 / max(abs(math.sin(msg.angle_min + i * msg.angle_increment)), 1e-3))
                      for i in range(301)]
        return msg

    def tf(self, stamp, x):
        t = TransformStamped()
        t.header.stamp = stamp
        t.header.frame_id = 'fault_odom'
        t.child_frame_id = 'fault_base'
        t.transform.translation.x = x
        t.transform.rotation.w = 1.0
        return TFMessage(transforms=[t])

    def test_grid_slam_restarts_only_on_a_real_jump(self):
        send_mount('fault_base', 'fault_laser')
        scan_pub = rospy.Publisher('/fault/scan', LaserScan, queue_size=50)
        tf_pub = rospy.Publisher('/tf', TFMessage, queue_size=50)
        folder = tempfile.mkdtemp()
        with tempfile.TemporaryFile('w+') as log:
            proc = subprocess.Popen(['rosrun', 'rbpf_slam', 'grid_slam', '__name:=fault_grid', 'scan:=/fault/scan',
                                     '_odom_frame:=fault_odom', '_base_frame:=fault_base', '_map_frame:=fault_map',
                                     '_particles:=5', '_linear_update:=0.0', '_angular_update:=0.0',
                                     '_map_path:=%s/grid_map.yaml' % folder],
                                    stdout=log, stderr=subprocess.STDOUT, universal_newlines=True)
            try:
                deadline = time.time() + TIMEOUT
                while time.time() < deadline and scan_pub.get_num_connections() == 0:
                    time.sleep(0.1)
                time.sleep(1.0)

                def send(stamp, x):
                    tf_pub.publish(self.tf(stamp, x))
                    time.sleep(0.02)
                    scan_pub.publish(self.scan(stamp))
                    time.sleep(0.08)
                x = 0.0
                for _ in range(10):
                    x += 0.02
                    send(rospy.Time.now(), x)
                late = rospy.Time.now() - rospy.Duration(0.5)
                scan_pub.publish(self.scan(late))  # 0.5 s late: dropped
                time.sleep(0.2)
                scan_pub.publish(self.scan(rospy.Time.now() + rospy.Duration(5.0)))  # from the future: dropped
                time.sleep(0.2)
                for _ in range(5):
                    x += 0.02
                    send(rospy.Time.now(), x)
                scan_pub.publish(self.scan(rospy.Time.now() - rospy.Duration(30.0)))  # one scan alone: dropped
                time.sleep(0.2)
                for _ in range(3):
                    x += 0.02
                    send(rospy.Time.now(), x)
                loop = rospy.Time.now() - rospy.Duration(30.0)
                for k in range(4):  # a loop: several scans agree, restart
                    scan_pub.publish(self.scan(loop + rospy.Duration(0.1 * k)))
                    time.sleep(0.1)
                time.sleep(0.5)
            finally:
                proc.send_signal(signal.SIGINT)
                proc.wait(10)
            log.seek(0)
            out = log.read()
        self.assertIn('before the previous stamp; dropped', out, out)
        self.assertIn('ahead of the clock; dropped', out, out)
        self.assertIn('before the previous stamp by more than the time jump threshold', out, out)
        self.assertEqual(out.count('time jumped back; the map is restarted'), 1, out)
        self.assertIn('reset 1', out)
        saved = os.path.join(folder, 'grid_map.restart1.yaml')
        self.assertIn('the map before restart 1 is saved to %s' % saved, out)
        self.assertTrue(os.path.isfile(saved) and os.path.isfile(saved[:-5] + '.pgm'), out)

    def test_grid_slam_survives_bad_scans(self):
        """Ranges NaN / +-Inf / 0 / huge, empty and all-NaN scans, beam-count changes, 4000 and 1 beams, bad
        increments, an unknown frame and a TF gap: the node stays up, names what it dropped, and maps on."""
        send_mount('bad_base', 'bad_laser')
        scan_pub = rospy.Publisher('/bad/scan', LaserScan, queue_size=50)
        tf_pub = rospy.Publisher('/tf', TFMessage, queue_size=50)
        inf, nan = float('inf'), float('nan')

        def variant(change):
            msg = self.scan(rospy.Time.now(), 'bad_laser')
            change(msg)
            return msg

        def tf(stamp, x):
            m = self.tf(stamp, x)
            m.transforms[0].header.frame_id = 'bad_odom'
            m.transforms[0].child_frame_id = 'bad_base'
            return m
        bad = [
            lambda m: setattr(m, 'ranges', [nan if i % 2 else inf for i in range(len(m.ranges))]),
            lambda m: setattr(m, 'ranges', [0.0] * len(m.ranges)),
            lambda m: setattr(m, 'ranges', [1e30] * len(m.ranges)),
            lambda m: setattr(m, 'ranges', [-inf] * len(m.ranges)),
            lambda m: setattr(m, 'ranges', []),
            lambda m: setattr(m, 'ranges', [nan] * len(m.ranges)),
            lambda m: setattr(m, 'ranges', m.ranges[:150]),
            lambda m: (setattr(m, 'angle_increment', 0.0008), setattr(m, 'ranges', [4.0] * 4000)),
            lambda m: setattr(m, 'ranges', [4.0]),
            lambda m: setattr(m, 'angle_increment', 0.0),
            lambda m: setattr(m, 'angle_increment', nan),
            lambda m: setattr(m, 'range_max', nan),
            lambda m: setattr(m.header, 'frame_id', 'nowhere'),
        ]
        with tempfile.TemporaryFile('w+') as log:
            proc = subprocess.Popen(['rosrun', 'rbpf_slam', 'grid_slam', '__name:=bad_scans_grid',
                                     'scan:=/bad/scan', '_odom_frame:=bad_odom', '_base_frame:=bad_base',
                                     '_map_frame:=bad_map', '_particles:=5', '_odom_timeout:=0.2'],
                                    stdout=log, stderr=subprocess.STDOUT, universal_newlines=True)
            try:
                deadline = time.time() + TIMEOUT
                while time.time() < deadline and scan_pub.get_num_connections() == 0:
                    time.sleep(0.1)
                time.sleep(1.0)
                x = 0.0
                for change in bad + [None, None]:
                    x += 0.2
                    stamp = rospy.Time.now()
                    tf_pub.publish(tf(stamp, x))
                    time.sleep(0.02)
                    msg = self.scan(stamp, 'bad_laser')
                    if change is not None:
                        change(msg)
                    scan_pub.publish(msg)
                    time.sleep(0.15)
                # A TF gap: a scan whose odometry never comes.
                scan_pub.publish(self.scan(rospy.Time.now(), 'bad_laser'))
                time.sleep(1.0)
                self.assertIsNone(proc.poll(), 'the node died')
            finally:
                proc.send_signal(signal.SIGINT)
                proc.wait(10)
            log.seek(0)
            out = log.read()
        self.assertNotIn('Segmentation', out)
        self.assertIn('scan has no ranges', out, out)
        self.assertIn('angle_increment', out, out)
        self.assertIn('no transform', out, out)

    def test_fastslam_keeps_its_map_through_bad_messages_and_saves_it_on_a_real_jump(self):
        """Every 4th odometry message 2 s back, arrays of unreadable trunks, an array of 10000 trunks and odometry
        with an all-zero quaternion: all dropped, the map kept. Then the bag loops: one restart, and the map before
        it saved beside ~map_path."""
        poses = []
        lock = threading.Lock()

        def on_pose(msg):
            with lock:
                poses.append(msg.header.stamp.to_sec())
        sub = rospy.Subscriber('/fault/pose', PoseWithCovarianceStamped, on_pose, queue_size=100)
        odom_pub = rospy.Publisher('/fault/odom', Odometry, queue_size=100)
        trunks_pub = rospy.Publisher('/fault/trunks', TrunkArray, queue_size=100)
        send_mount('fault_base', 'fault_lidar')
        nan = float('nan')

        def odometry(stamp, x, w=1.0):
            od = Odometry()
            od.header.stamp = stamp
            od.header.frame_id = 'fault_odom'
            od.pose.pose.position.x = x
            od.pose.pose.orientation.w = w
            return od

        def trunks(stamp, x, bad=False, many=1):
            a = TrunkArray()
            a.header.stamp = stamp
            a.header.frame_id = 'fault_lidar'
            for (tx, ty) in ((4.0, 1.0), (6.0, -2.0), (3.0, -3.0)) * many:
                t = Trunk()
                t.center.x, t.center.y = tx - x, (nan if bad else ty)
                t.radius, t.radius_variance = 0.2, 1e-4
                t.range, t.bearing = math.hypot(t.center.x, ty), math.atan2(ty, t.center.x)
                t.covariance = [1e-3, 0.0, 0.0, 1e-3]
                t.method = Trunk.METHOD_CIRCLE
                a.trunks.append(t)
            return a

        def drive(t0, n, late_every=0, bad_from=None):
            odom_pub.publish(odometry(t0 - rospy.Duration(0.05), 0.0))
            for k in range(n):
                stamp = t0 + rospy.Duration(0.1 * k)
                odom_pub.publish(odometry(stamp + rospy.Duration(0.05), 0.05 * k))
                if late_every and k % late_every == late_every - 1:
                    odom_pub.publish(odometry(stamp - rospy.Duration(2.0), 0.0))  # 2 s late
                trunks_pub.publish(trunks(stamp, 0.05 * k, bad=bad_from is not None and k >= bad_from))
                time.sleep(0.05)

        folder = tempfile.mkdtemp()
        with tempfile.TemporaryFile('w+') as log:
            proc = subprocess.Popen(['rosrun', 'rbpf_slam', 'fastslam', '__name:=fault_fastslam',
                                     'odom:=/fault/odom', 'trunks:=/fault/trunks', 'pose:=/fault/pose',
                                     '_odom_frame:=fault_odom', '_base_frame:=fault_base', '_map_frame:=fault_map',
                                     '_particles:=20', '_map_path:=%s/forest_map.csv' % folder],
                                    stdout=log, stderr=subprocess.STDOUT, universal_newlines=True)
            try:
                deadline = time.time() + TIMEOUT
                while time.time() < deadline and (trunks_pub.get_num_connections() == 0 or
                                                  odom_pub.get_num_connections() == 0 or
                                                  sub.get_num_connections() == 0):
                    time.sleep(0.1)
                time.sleep(1.0)
                first_start = rospy.Time.now()
                # 20 sweeps that map the three trunks, then 12 whose trunks are all unreadable (NaN).
                drive(first_start, 32, late_every=4, bad_from=20)
                end = first_start + rospy.Duration(3.3)
                rss_before = rss_mb(proc.pid)
                for k in range(3):  # three arrays of 10000 trunks each
                    odom_pub.publish(odometry(end + rospy.Duration(0.1 * k), 1.6))
                    trunks_pub.publish(trunks(end + rospy.Duration(0.1 * k), 1.6, many=3334))
                    time.sleep(0.3)
                odom_pub.publish(odometry(end + rospy.Duration(0.5), 1.6, w=0.0))  # all-zero quaternion
                time.sleep(1.0)
                rss_after = rss_mb(proc.pid)
                with lock:
                    before = len(poses)
                loop_start = first_start - rospy.Duration(60.0)  # the bag starts again
                drive(loop_start, 20)
                time.sleep(1.5)
                self.assertIsNone(proc.poll(), 'the node died')
            finally:
                proc.send_signal(signal.SIGINT)
                proc.wait(10)
            log.seek(0)
            out = log.read()
        sub.unregister()
        self.assertGreater(before, 10, 'the first drive was not processed:\n' + out)
        with lock:
            looped = [t for t in poses[before:] if t < first_start.to_sec()]
        self.assertGreater(len(looped), 10, 'after the loop the filter stayed frozen:\n' + out)
        self.assertEqual(out.count('time jumped back; the filter restarts'), 1, out)
        self.assertIn('before the previous stamp by more than the time jump threshold', out)
        self.assertIn('the array is dropped (not a look that saw no tree)', out)
        self.assertIn('more detections than the sensor can see', out)
        self.assertIn('orientation not a unit quaternion', out)
        print('three arrays of 10000 trunks: the node %.1f MB before, %.1f MB after' % (rss_before, rss_after))
        self.assertLess(rss_after - rss_before, 20.0, 'three arrays of 10000 trunks took %.1f MB' %
                        (rss_after - rss_before))
        # The map before the restart: the three trees, kept through the late and the unreadable messages.
        saved = os.path.join(folder, 'forest_map.restart1.csv')
        self.assertIn('is saved to %s' % saved, out)
        with open(saved) as f:
            rows = [l for l in f.read().splitlines() if l and not l.startswith('#')]
        self.assertEqual(len(rows), 1 + 3, 'expected the header and 3 trees:\n' + '\n'.join(rows))

    def test_two_fastslam_nodelets_in_one_manager_name_the_transforms_owner(self):
        with tempfile.TemporaryFile('w+') as log:
            manager = subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'manager', '__name:=tf_manager'],
                                       stdout=log, stderr=subprocess.STDOUT, universal_newlines=True)
            loads = []
            try:
                for name in ('fastslam_first', 'fastslam_second'):
                    loads.append(subprocess.Popen(['rosrun', 'nodelet', 'nodelet', 'load', 'rbpf_slam/FastSlamNodelet',
                                                   'tf_manager', '__name:=' + name, '_particles:=5',
                                                   'odom:=/%s/odom' % name, 'trunks:=/%s/trunks' % name],
                                                  stdout=log, stderr=subprocess.STDOUT, universal_newlines=True))
                    time.sleep(3.0)
                time.sleep(1.0)
            finally:
                for p in loads + [manager]:
                    p.send_signal(signal.SIGINT)
                for p in loads + [manager]:
                    p.wait(10)
            log.seek(0)
            out = log.read()
        self.assertIn('/fastslam_second: map -> odom is already published by /fastslam_first in this process', out, out)
        self.assertNotIn('/fastslam_first: map -> odom is already', out, out)


class NodeFaults(ConfigFaults, TimeFaults, unittest.TestCase):
    pass


if __name__ == '__main__':
    rospy.init_node('node_faults_check')
    rostest.rosrun('rbpf_slam', 'node_faults', NodeFaults)
