"""The converter commands as a user runs them: --help with an example, exit codes, messages, installation,
the speed benchmark; and the shared helpers of convert_common."""
import os
import re
import subprocess
import sys

import pytest

from bagcheck import DATA, ROOT
from rbpf_slam import convert_common as cc

COMMANDS = ('carmen_to_bag', 'ese650_to_bag', 'freiburg_to_bag', 'lego_to_bag', 'mrclam_to_bag',
            'victoria_park_to_bag')


def run(name, *args):
    return subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', name)] + list(args),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, timeout=120)


@pytest.mark.parametrize('name', COMMANDS + ('converter_benchmark',))
def test_script_is_an_installed_python3_program(name):
    path = os.path.join(ROOT, 'scripts', name)
    assert os.access(path, os.X_OK)
    with open(path) as f:
        assert f.readline().strip() == '#!/usr/bin/env python3'
    with open(os.path.join(ROOT, 'CMakeLists.txt')) as f:
        cmake = f.read()
    block = re.search(r'catkin_install_python\(PROGRAMS\n(.*?)\n  DESTINATION', cmake, re.S).group(1).split()
    assert 'scripts/' + name in block
    assert block == sorted(block), 'keep the catkin_install_python list sorted'


@pytest.mark.parametrize('name', COMMANDS)
def test_help_has_an_example_and_the_options(name):
    r = run(name, '--help')
    assert r.returncode == 0, r.stderr
    assert 'Example:' in r.stdout and name + ' ' in r.stdout.split('Example:')[1]
    for option in ('--output', '--skip-bad', '--limit', '--odom-topic', '--odom-frame', '--base-frame'):
        assert option in r.stdout


def test_command_end_to_end(tmp_path):
    d = tmp_path / 'd'
    d.mkdir()
    (d / 'sensor_data.dat').write_text('ODOMETRY 0 1 0\nSENSOR 1 2 0.1\nODOMETRY 0 1 0\n')
    (d / 'world.dat').write_text('1 3 0\n')
    out = tmp_path / 'f.bag'
    r = run('freiburg_to_bag', str(d), '-o', str(out))
    assert r.returncode == 0, r.stderr
    assert 'freiburg_to_bag: wrote' in r.stdout and re.search(r'/odom\s+3\n', r.stdout)
    assert out.exists() and sorted(os.listdir(str(tmp_path))) == ['d', 'f.bag']


def test_command_error_and_usage(tmp_path):
    d = tmp_path / 'd'
    d.mkdir()
    (d / 'sensor_data.dat').write_text('ODOMETRY 0 1 0\nODOMETRY 0 one 0\n')
    r = run('freiburg_to_bag', str(d), '-o', str(tmp_path / 'f.bag'))
    assert r.returncode == 1
    assert r.stderr == "freiburg_to_bag: %s:2: expected numbers as r1 t r2, got 'one'\n" % (d / 'sensor_data.dat')
    assert not (tmp_path / 'f.bag').exists()
    r = run('freiburg_to_bag', str(d), '-o', str(tmp_path / 'f.txt'))
    assert r.returncode == 2 and 'must be a .bag file' in r.stderr
    r = run('lego_to_bag', str(tmp_path / 'nowhere'), '-o', str(tmp_path / 'l.bag'))
    assert r.returncode == 1 and 'no such file' in r.stderr


def test_speed_benchmark():
    if not os.path.isfile(os.path.join(DATA, 'carmen', 'intel-corrected.log.gz')):
        pytest.skip('real data not found in %s' % DATA)
    r = run('converter_benchmark', '--data', DATA)
    assert r.returncode == 0, r.stdout + r.stderr
    assert 'CARMEN Intel' in r.stdout and 'ESE 650 run 20' in r.stdout and 'x real time' in r.stdout
    rows = [line for line in r.stdout.splitlines() if line.startswith(('CARMEN Intel', 'ESE 650 run'))]
    assert len(rows) == 3, r.stdout
    for line in rows:  # each conversion at least 10 times faster than the log's time span
        assert float(line.split()[-2]) >= 10.0, r.stdout


@pytest.mark.parametrize('name', ('converter_benchmark', 'lego_benchmark'))
def test_benchmark_without_data_directory_is_a_clear_error(name):
    env = dict(os.environ)
    env.pop('RBPF_SLAM_DATA', None)
    r = subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', name)], env=env,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, timeout=120)
    assert r.returncode == 2 and r.stdout == ''
    assert r.stderr.startswith(name + ': ') and len(r.stderr.splitlines()) == 1, r.stderr
    assert '--data' in r.stderr and 'RBPF_SLAM_DATA' in r.stderr, r.stderr


def test_conversion_error_text():
    e = cc.ConversionError('a.log', 12, 'ODOM x y theta', got='3 fields')
    assert str(e) == 'a.log:12: expected ODOM x y theta, got 3 fields'
    assert str(cc.ConversionError('a.mat', None, 'a struct')) == 'a.mat: expected a struct'


def test_bad_lines_policy():
    stop = cc.BadLines(skip_bad=False)
    with pytest.raises(cc.ConversionError):
        stop(cc.ConversionError('f', 1, 'x'))
    skip = cc.BadLines(skip_bad=True)
    for line in range(1, 8):
        skip(cc.ConversionError('f', line, 'x'))
    assert skip.count == 7 and skip.reasons['x'] == 7 and len(skip.examples) == 5


def test_se2_helpers():
    a = (1.0, 2.0, 0.5)
    b = (0.3, -0.1, 1.0)
    c = cc.se2_compose(a, b)
    assert cc.se2_between(a, c) == pytest.approx(b)
    assert float(cc.wrap_angle(3 * 3.141592653589793)) == pytest.approx(-3.141592653589793)
