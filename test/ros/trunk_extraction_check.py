#!/usr/bin/env python3
"""rostest node: drives the trunk extraction nodelet (in a manager) with synthetic input.

One trunk of radius 0.2 m stands 4 m ahead of the sensors: as a half cylinder of points above a flat
ground 1.8 m below the 3D lidar (frame velodyne), and as an arc of a 2D scan (frame laser). Each input
carries a unique stamp, so every TrunkArray can be traced to the input it answers. The extraction
levels clouds by TF with ~level_frame base_link; this node publishes base_link -> velodyne on
/tf_static with only a heading (yaw), which the nodelet must strip (the trunks stay in the sensor frame).

Checks: a TrunkArray with the input's header for every usable cloud and scan; every malformed kind of cloud
(and unusable scans) is dropped - no TrunkArray, a report on ~stats - without crashing the manager or blocking
the answer to the next cloud; clouds of an unknown frame are answered unlevelled;
markers are made only while someone subscribes; dynamic_reconfigure starts from the parameters (not
the .cfg defaults), applies a valid change and refuses an invalid one.
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from dynamic_reconfigure.client import Client
from geometry_msgs.msg import TransformStamped
from rbpf_slam.msg import Trunk, TrunkArray
from sensor_msgs import point_cloud2
from sensor_msgs.msg import LaserScan, PointCloud2, PointField
from std_msgs.msg import Header, String
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

TRUNK_X, TRUNK_Y, TRUNK_R = 4.0, 0.0, 0.2
SENSOR_HEIGHT = 1.8
TIMEOUT = 10.0
NAN = float('nan')


def trunk_points():
    """A half cylinder facing the sensor, from the ground to 0.6 m above the sensor, on a flat ground."""
    points = []
    for k in range(49):
        z = -SENSOR_HEIGHT + 0.05 * k
        for j in range(31):
            phi = math.pi - 1.2 + 0.08 * j
            points.append((TRUNK_X + TRUNK_R * math.cos(phi), TRUNK_Y + TRUNK_R * math.sin(phi), z))
    for i in range(65):
        for j in range(49):
            x, y = -6.0 + 0.25 * i, -6.0 + 0.25 * j
            if math.hypot(x - TRUNK_X, y - TRUNK_Y) > TRUNK_R + 0.05:
                points.append((x, y, -SENSOR_HEIGHT))
    return points


def trunk_scan_ranges(angle_min, increment, count):
    """Ranges of a 2D scan that sees only the trunk (+Inf elsewhere, REP-117); one NaN beam."""
    ranges = []
    for i in range(count):
        a = angle_min + i * increment
        dx, dy = math.cos(a), math.sin(a)
        b = dx * TRUNK_X + dy * TRUNK_Y  # ray p = t d meets |p - c| = r where t^2 - 2 b t + |c|^2 - r^2 = 0
        disc = b * b - (TRUNK_X ** 2 + TRUNK_Y ** 2 - TRUNK_R ** 2)
        ranges.append(b - math.sqrt(disc) if disc >= 0.0 else float('inf'))
    ranges[0] = NAN
    return ranges


class TrunkExtractionCheck(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.node = rospy.get_param('~extraction', '/trunk_extraction')
        cls.lock = threading.Lock()
        cls.trunks = []
        cls.stats = []
        cls.markers = []
        cls.next_stamp = 2000
        cls.points = trunk_points()

        def keep(store):
            def cb(msg):
                with cls.lock:
                    store.append(msg)
            return cb

        cls.tf_pub = rospy.Publisher('/tf_static', TFMessage, queue_size=1, latch=True)
        mount = TransformStamped()
        mount.header.stamp = rospy.Time(1)
        mount.header.frame_id = 'base_link'
        mount.child_frame_id = 'velodyne'
        mount.transform.translation.z = SENSOR_HEIGHT
        mount.transform.rotation.z = math.sin(0.25)  # yaw 0.5 rad
        mount.transform.rotation.w = math.cos(0.25)
        cls.tf_pub.publish(TFMessage(transforms=[mount]))

        cls.trunk_sub = rospy.Subscriber('trunks', TrunkArray, keep(cls.trunks), queue_size=100)
        cls.stats_sub = rospy.Subscriber(cls.node + '/stats', String, keep(cls.stats), queue_size=100)
        cls.cloud_pub = rospy.Publisher('points', PointCloud2, queue_size=10)
        cls.scan_pub = rospy.Publisher('scan', LaserScan, queue_size=10)
        deadline = time.time() + 30.0
        while time.time() < deadline and not rospy.is_shutdown():
            if all(x.get_num_connections() > 0 for x in (cls.trunk_sub, cls.stats_sub, cls.cloud_pub, cls.scan_pub)):
                break
            time.sleep(0.05)
        time.sleep(0.5)  # let the nodelet see our subscriptions before the first input

    # --- helpers ------------------------------------------------------------------------------------
    def header(self, frame):
        cls = type(self)
        cls.next_stamp += 1
        return Header(stamp=rospy.Time(cls.next_stamp, 250000000), frame_id=frame)

    def cloud(self, frame='velodyne', points=None):
        return point_cloud2.create_cloud_xyz32(self.header(frame), self.points if points is None else points)

    def scan(self, frame='laser'):
        msg = LaserScan(header=self.header(frame))
        msg.angle_min, msg.angle_increment = -1.0, 0.005
        msg.angle_max = msg.angle_min + 400 * msg.angle_increment
        msg.range_min, msg.range_max = 0.1, 30.0
        msg.ranges = trunk_scan_ranges(msg.angle_min, msg.angle_increment, 401)
        return msg

    def wait_for(self, store, match, timeout=TIMEOUT):
        deadline = time.time() + timeout
        while time.time() < deadline and not rospy.is_shutdown():
            with self.lock:
                for msg in store:
                    if match(msg):
                        return msg
            time.sleep(0.02)
        return None

    def answer(self, header, timeout=TIMEOUT):
        msg = self.wait_for(self.trunks, lambda m: m.header.stamp == header.stamp, timeout)
        self.assertIsNotNone(msg, 'no TrunkArray answered the input stamped %.3f' % header.stamp.to_sec())
        self.assertEqual(msg.header.frame_id, header.frame_id, 'the TrunkArray must carry the input header')
        return msg

    def stats_for(self, header):
        def match(m):
            fields = dict(kv.split('=', 1) for kv in m.data.split() if '=' in kv)
            return abs(float(fields['stamp']) - header.stamp.to_sec()) < 1e-6
        msg = self.wait_for(self.stats, match)
        self.assertIsNotNone(msg, 'no ~stats for the input stamped %.3f' % header.stamp.to_sec())
        return dict(kv.split('=', 1) for kv in msg.data.split() if '=' in kv)

    def assert_the_trunk(self, array):
        self.assertEqual(len(array.trunks), 1, 'expected exactly the one synthetic trunk: %s' % array.trunks)
        t = array.trunks[0]
        self.assertAlmostEqual(t.center.x, TRUNK_X, delta=0.1)
        self.assertAlmostEqual(t.center.y, TRUNK_Y, delta=0.1)
        self.assertAlmostEqual(t.radius, TRUNK_R, delta=0.05)
        self.assertAlmostEqual(t.range, math.hypot(t.center.x, t.center.y), delta=1e-6)
        self.assertAlmostEqual(t.bearing, math.atan2(t.center.y, t.center.x), delta=1e-6)
        self.assertEqual(len(t.covariance), 4)
        self.assertTrue(all(math.isfinite(c) for c in t.covariance))
        self.assertGreater(t.covariance[0], 0.0)
        self.assertAlmostEqual(t.covariance[1], t.covariance[2], delta=1e-12)
        self.assertGreater(t.radius_variance, 0.0)
        self.assertGreaterEqual(t.num_points, t.num_inliers)
        self.assertGreater(t.num_inliers, 0)
        self.assertTrue(0.0 <= t.score <= 1.0)
        self.assertIn(t.method, (Trunk.METHOD_CENTROID, Trunk.METHOD_CIRCLE, Trunk.METHOD_ARC))
        self.assertEqual(t.id, -1)

    # --- tests ----------------------------------------------------------------------------------------
    def test_cloud_gives_trunks_in_its_frame(self):
        msg = self.cloud()
        self.cloud_pub.publish(msg)
        array = self.answer(msg.header)
        self.assert_the_trunk(array)
        self.assertLess(array.trunks[0].center.z, 0.0, 'the band lies below a sensor 1.8 m up')

    def test_scan_gives_trunks_in_its_frame(self):
        msg = self.scan()
        self.scan_pub.publish(msg)
        array = self.answer(msg.header)
        self.assert_the_trunk(array)
        # The scope it states is the scan's own: its first and last beam, its ranges within the extraction's.
        last = msg.angle_min + (len(msg.ranges) - 1) * msg.angle_increment
        self.assertAlmostEqual(array.fov_min, min(msg.angle_min, last), places=6)
        self.assertAlmostEqual(array.fov_max, max(msg.angle_min, last), places=6)
        self.assertAlmostEqual(array.max_range, min(msg.range_max, rospy.get_param(self.node + '/max_range', 30.0)),
                               places=6)
        self.assertGreaterEqual(array.min_range, msg.range_min)

    def malformed_clouds(self):
        """Every malformed kind of cloud: each must be dropped (no TrunkArray), reported, and survived."""
        def spoiled(change):
            msg = self.cloud()
            change(msg)
            return msg
        xyz = [PointField(n, 4 * i, PointField.FLOAT32, 1) for i, n in enumerate('xyz')]
        def timed_cloud(offset):
            timed = [PointField(n, 4 * i, PointField.FLOAT32, 1) for i, n in enumerate('xyz')] + \
                [PointField('time', 12, PointField.FLOAT32, 1)]
            msg = point_cloud2.create_cloud(self.header('velodyne'), timed,
                                            [(x, y, z, 0.0) for x, y, z in self.points])
            msg.fields[3].offset = offset
            return msg
        kinds = {
            'empty': PointCloud2(header=self.header('velodyne'), height=1, width=0, point_step=12, row_step=0,
                                 fields=xyz),
            'data short': spoiled(lambda m: setattr(m, 'data', m.data[:len(m.data) // 2])),
            'data 5 bytes long': spoiled(lambda m: setattr(m, 'data', m.data + b'\0' * 5)),
            'no z': spoiled(lambda m: setattr(m, 'fields', [f for f in m.fields if f.name != 'z'])),
            'x int8': spoiled(lambda m: setattr(m.fields[0], 'datatype', PointField.INT8)),
            'z beyond the point': spoiled(lambda m: setattr(m.fields[2], 'offset', 10)),
            'time beyond the point': timed_cloud(1000000),
            'time straddling the point': timed_cloud(14),
            'row_step short': spoiled(lambda m: setattr(m, 'row_step', 4)),
            'height lies': spoiled(lambda m: setattr(m, 'height', 1000)),
            'big endian': spoiled(lambda m: setattr(m, 'is_bigendian', True)),
            'all NaN': self.cloud(points=[(NAN, NAN, NAN)] * 100),
        }
        return kinds

    def test_bad_clouds_are_dropped_reported_and_survived(self):
        for name, msg in self.malformed_clouds().items():
            self.cloud_pub.publish(msg)
            stats = self.stats_for(msg.header)
            self.assertIn('reason', stats, '%s: ~stats must say why the cloud was dropped: %s' % (name, stats))
            # A dropped cloud is no look that saw no tree: no TrunkArray is published for it.
            valid = self.cloud()
            self.cloud_pub.publish(valid)
            self.assert_the_trunk(self.answer(valid.header))
            with self.lock:
                answered = [a for a in self.trunks if a.header.stamp == msg.header.stamp]
            self.assertEqual(answered, [], '%s: a malformed cloud must publish no TrunkArray' % name)
        some_nan = self.cloud(points=self.points + [(NAN, 1.0, 2.0), (float('inf'), 0.0, 0.0)] * 50)
        unknown_frame = self.cloud(frame='nowhere')  # no TF to level_frame: a warning, no levelling
        for msg in (some_nan, unknown_frame):
            self.cloud_pub.publish(msg)
            self.assert_the_trunk(self.answer(msg.header))

    def test_bad_scans_are_dropped_and_dropouts_make_no_trunk(self):
        all_nan = self.scan()
        all_nan.ranges = [NAN] * len(all_nan.ranges)
        no_increment = self.scan()
        no_increment.angle_increment = 0.0
        for msg in (all_nan, no_increment):
            self.scan_pub.publish(msg)
            self.assertIn('reason', self.stats_for(msg.header))
        # Dropouts inside the trunk's arc (every 3rd beam NaN, -Inf or 0) still give the one trunk.
        for bad in (NAN, float('-inf'), 0.0):
            msg = self.scan()
            msg.ranges = [bad if i % 3 == 0 else r for i, r in enumerate(msg.ranges)]
            self.scan_pub.publish(msg)
            self.assert_the_trunk(self.answer(msg.header))

    def test_markers_only_while_subscribed(self):
        first = self.cloud()
        self.cloud_pub.publish(first)
        self.answer(first.header)
        self.assertEqual(self.stats_for(first.header)['markers_published'], '0',
                         'markers were made with nobody subscribed')

        sub = rospy.Subscriber('trunk_markers', MarkerArray, lambda m: self.markers.append(m), queue_size=10)
        deadline = time.time() + TIMEOUT
        while sub.get_num_connections() == 0 and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(0.5)
        second = self.cloud()
        self.cloud_pub.publish(second)
        self.answer(second.header)
        markers = self.wait_for(self.markers, lambda m: m.markers and m.markers[0].header.stamp == second.header.stamp)
        self.assertIsNotNone(markers, 'no markers while subscribed')
        self.assertEqual(markers.markers[0].action, Marker.DELETEALL)
        cylinders = [m for m in markers.markers if m.type == Marker.CYLINDER]
        labels = [m for m in markers.markers if m.type == Marker.TEXT_VIEW_FACING]
        self.assertEqual(len(cylinders), 1)
        self.assertEqual(len(labels), 1)
        self.assertEqual(cylinders[0].header.frame_id, 'velodyne')
        self.assertAlmostEqual(cylinders[0].scale.x, 2 * TRUNK_R, delta=0.1)
        band = rospy.get_param(self.node + '/max_height') - rospy.get_param(self.node + '/min_height')
        self.assertAlmostEqual(cylinders[0].scale.z, band, delta=1e-6)
        self.assertTrue(labels[0].text.endswith(' cm'), labels[0].text)
        self.assertAlmostEqual(float(labels[0].text.split()[0]), 20.0, delta=5.0)
        made = int(self.stats_for(second.header)['markers_published'])
        self.assertGreaterEqual(made, 1)

        sub.unregister()
        time.sleep(1.0)
        third = self.cloud()
        self.cloud_pub.publish(third)
        self.answer(third.header)
        self.assertEqual(int(self.stats_for(third.header)['markers_published']), made,
                         'markers were made after the subscriber left')

    def test_reconfigure(self):
        client = Client(self.node, timeout=30)
        try:
            current = client.get_configuration(timeout=10)
            # The test sets min_height 0.45 (the .cfg default is 0.8): the server must keep the parameter.
            self.assertAlmostEqual(current['min_height'], rospy.get_param(self.node + '/min_height'))
            self.assertAlmostEqual(current['min_height'], 0.45)
            self.assertEqual(current['method'], 'circle')

            applied = client.update_configuration({'method': 'centroid'})
            self.assertEqual(applied['method'], 'centroid')
            msg = self.cloud()
            self.cloud_pub.publish(msg)
            array = self.answer(msg.header)
            self.assertTrue(array.trunks)
            self.assertTrue(all(t.method == Trunk.METHOD_CENTROID for t in array.trunks))

            # Every array states the scope it was found in: a cloud all round, out to at most max_range, with the
            # detection probability, which is live too.
            self.assertAlmostEqual(array.fov_min, -math.pi)
            self.assertAlmostEqual(array.fov_max, math.pi)
            self.assertGreater(array.max_range, array.min_range)
            self.assertLessEqual(array.max_range, current['max_range'] + 1e-9)
            self.assertAlmostEqual(array.detection_probability, current['detection_probability'])
            client.update_configuration({'detection_probability': 0.6})
            msg = self.cloud()
            self.cloud_pub.publish(msg)
            self.assertAlmostEqual(self.answer(msg.header).detection_probability, 0.6)
            client.update_configuration({'detection_probability': current['detection_probability']})

            refused = client.update_configuration({'min_radius': 0.5, 'max_radius': 0.3})
            self.assertAlmostEqual(refused['min_radius'], current['min_radius'], msg='an invalid set was applied')
            self.assertAlmostEqual(refused['max_radius'], current['max_radius'])
            self.assertEqual(refused['method'], 'centroid', 'the previous configuration must stay')
        finally:
            client.update_configuration({'method': 'circle'})
            client.close()
        msg = self.cloud()
        self.cloud_pub.publish(msg)
        self.assert_the_trunk(self.answer(msg.header))


if __name__ == '__main__':
    rospy.init_node('trunk_extraction_check')
    rostest.rosrun('rbpf_slam', 'trunk_extraction_check', TrunkExtractionCheck)
