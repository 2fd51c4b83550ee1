"""The launch files load the configurations their users are told to give them (roslaunch --dump-params, no master):
an odometry class and a sensor configuration reach FastSLAM through replay.launch, robot.launch and localize.launch;
grid SLAM gets its two shipped files through replay.launch and grid_slam.launch."""
import os
import subprocess

import pytest
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIG = os.path.join(ROOT, 'config')


def _load(path):
    with open(path) as f:
        return yaml.safe_load(f)


def dump_params(launch, *args):
    r = subprocess.run(['roslaunch', '--dump-params', 'rbpf_slam', launch] + list(args), stdout=subprocess.PIPE,
                       stderr=subprocess.PIPE, universal_newlines=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return yaml.safe_load(r.stdout)


def _flatten(prefix, d, out):
    for k, v in d.items():
        if isinstance(v, dict):
            _flatten(prefix + k + '/', v, out)
        else:
            out[prefix + k] = v
    return out


@pytest.mark.parametrize('launch,extra', [('replay.launch', ['bag:=', 'gui:=false']),
                                          ('robot.launch', []),
                                          ('localize.launch', ['map_file:=/tmp/trees.csv'])])
def test_an_odometry_class_and_a_sensor_configuration_reach_fastslam(launch, extra):
    car = os.path.join(CONFIG, 'odometry', 'car.yaml')
    scanner = os.path.join(CONFIG, 'scanner_2d.yaml')
    params = dump_params(launch, 'odometry:=' + car, 'sensor_config:=' + scanner, *extra)
    expected = _flatten('/fastslam/', _load(car), {})
    _flatten('/fastslam/', _load(scanner), expected)
    assert expected  # the files hold keys
    for key, value in expected.items():
        assert params.get(key) == value, (launch, key, params.get(key), value)
    # Without them: the shipped FastSLAM files alone (the car's motion noise is not the default's).
    default = dump_params(launch, *extra)
    assert default.get('/fastslam/motion/alpha1') != _load(car)['motion']['alpha1'] or \
        default.get('/fastslam/motion_step') != _load(car)['motion_step']


@pytest.mark.parametrize('launch,extra', [('replay.launch', ['slam:=grid', 'bag:=', 'gui:=false']),
                                          ('grid_slam.launch', [])])
def test_grid_slam_gets_its_two_shipped_files(launch, extra):
    params = dump_params(launch, *extra)
    expected = _flatten('/grid_slam/', _load(os.path.join(CONFIG, 'grid_slam_advanced.yaml')), {})
    _flatten('/grid_slam/', _load(os.path.join(CONFIG, 'grid_slam.yaml')), expected)
    expected['/grid_slam/seed'] = 0  # the launch argument
    for key, value in expected.items():
        assert params.get(key) == value, (launch, key, params.get(key), value)
