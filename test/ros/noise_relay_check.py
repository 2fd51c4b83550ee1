#!/usr/bin/env python3
"""rostest node: drives the noise relay and checks its output.

Each command carries its index in linear.y (a field the relay passes through unchanged), so every
output can be traced to exactly one input. Expected sigmas are read from the relay's own parameters.
"""
import math
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist, TwistStamped

N_COMMANDS = 1000
LINEAR = 1.2
ANGULAR = -0.5


class NoiseRelayCheck(unittest.TestCase):
    def setUp(self):
        self.relay = rospy.get_param('~relay', '/noise_relay')
        self.stamped = rospy.get_param(self.relay + '/stamped', False)
        self.msg_type = TwistStamped if self.stamped else Twist
        self.outputs = []
        self.sub = rospy.Subscriber('cmd_vel_noisy', self.msg_type, self.outputs.append, queue_size=None)
        self.pub = rospy.Publisher('cmd_vel', self.msg_type, queue_size=N_COMMANDS)
        deadline = rospy.Time.now() + rospy.Duration(20.0)
        while (self.pub.get_num_connections() == 0 or self.sub.get_num_connections() == 0) \
                and rospy.Time.now() < deadline and not rospy.is_shutdown():
            rospy.sleep(0.05)
        self.assertGreater(self.pub.get_num_connections(), 0, 'the relay never subscribed to cmd_vel')
        self.assertGreater(self.sub.get_num_connections(), 0, 'the relay never published cmd_vel_noisy')
        rospy.sleep(0.5)  # let the relay see our subscription before the first command

    def make(self, index, linear, angular):
        twist = Twist()
        twist.linear.x = linear
        twist.linear.y = float(index)
        twist.linear.z = 0.25
        twist.angular.z = angular
        if not self.stamped:
            return twist
        msg = TwistStamped()
        msg.header.stamp = rospy.Time(1000 + index)
        msg.header.frame_id = 'base_link'
        msg.twist = twist
        return msg

    def twist_of(self, msg):
        return msg.twist if self.stamped else msg

    def test_noise_statistics_and_one_output_per_command(self):
        rate = rospy.Rate(250)
        for i in range(N_COMMANDS):
            self.pub.publish(self.make(i, LINEAR, ANGULAR))
            if i == N_COMMANDS // 2:
                self.pub.publish(self.make(-1, float('nan'), ANGULAR))  # must be dropped
            rate.sleep()
        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while len(self.outputs) < N_COMMANDS and rospy.Time.now() < deadline:
            rospy.sleep(0.05)
        rospy.sleep(0.5)  # anything extra would arrive now

        indices = [int(self.twist_of(m).linear.y) for m in self.outputs]
        self.assertNotIn(-1, indices, 'a NaN command was relayed')
        self.assertEqual(sorted(indices), list(range(N_COMMANDS)),
                         'expected exactly one output per command')
        for msg in self.outputs:
            self.assertEqual(self.twist_of(msg).linear.z, 0.25, 'unperturbed fields must pass through')
            if self.stamped:
                index = int(msg.twist.linear.y)
                self.assertEqual(msg.header.stamp, rospy.Time(1000 + index), 'header must pass through')
                self.assertEqual(msg.header.frame_id, 'base_link')

        def expected_sigma(kind, command):
            absolute = rospy.get_param('%s/%s_sigma_abs' % (self.relay, kind))
            relative = rospy.get_param('%s/%s_sigma_rel' % (self.relay, kind))
            return math.hypot(absolute, relative * command)

        n = float(len(self.outputs))
        for kind, command, values in (
                ('linear', LINEAR, [self.twist_of(m).linear.x for m in self.outputs]),
                ('angular', ANGULAR, [self.twist_of(m).angular.z for m in self.outputs])):
            sigma = expected_sigma(kind, command)
            self.assertGreater(sigma, 0.0, 'the test needs a noisy relay')
            mean = sum(values) / n
            std = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1))
            # 5 standard errors: sigma / sqrt(n) for the mean, sigma / sqrt(2 n) for the std.
            self.assertAlmostEqual(mean, command, delta=5 * sigma / math.sqrt(n),
                                   msg='%s mean %.4f, commanded %.4f' % (kind, mean, command))
            self.assertAlmostEqual(std, sigma, delta=5 * sigma / math.sqrt(2 * n),
                                   msg='%s std %.4f, expected %.4f' % (kind, std, sigma))


if __name__ == '__main__':
    rospy.init_node('noise_relay_check')
    rostest.rosrun('rbpf_slam', 'noise_relay_check', NoiseRelayCheck)
