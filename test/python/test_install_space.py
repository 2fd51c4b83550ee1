"""The package as installed (`catkin_make install`): found by ROS in the install space alone, the offline demo
(fastslam_benchmark + plot_forest_run --report) and the live demo (forest_demo.launch, headless) run from it.

scripts/test installs the workspace into RBPF_INSTALL (default: RBPF_WS/install) before the pytests. Every
command runs in a clean environment that sources only the install space's setup.bash, so nothing of the source
tree or the devel space can stand in for a missing installed file."""
import json
import os
import signal
import socket
import subprocess
import tempfile
import time

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WS = os.environ.get('RBPF_WS', os.path.join(ROOT, 'build'))
INSTALL = os.path.abspath(os.environ.get('RBPF_INSTALL', os.path.join(WS, 'install')))

pytestmark = pytest.mark.skipif(not os.path.isfile(os.path.join(INSTALL, 'setup.bash')),
                                reason='no install space at %s (scripts/test makes it: catkin_make install)' % INSTALL)

TF_CHECK = r'''
import sys, rospy
from tf2_msgs.msg import TFMessage
seen = set()
def on_tf(msg):
    for t in msg.transforms:
        seen.add((t.header.frame_id.lstrip('/'), t.child_frame_id.lstrip('/')))
rospy.init_node('install_space_check', anonymous=True)
rospy.Subscriber('/tf', TFMessage, on_tf)
import time
end = time.time() + float(sys.argv[1])
while time.time() < end and ('map', 'odom') not in seen:
    time.sleep(0.2)
print(sorted(seen))
sys.exit(0 if ('map', 'odom') in seen else 1)
'''


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _env(tmp, port=None):
    env = {'HOME': os.environ.get('HOME', tmp), 'PATH': '/usr/bin:/bin', 'LANG': 'C.UTF-8',
           'ROS_HOSTNAME': 'localhost', 'ROS_LOG_DIR': os.path.join(tmp, 'log'), 'ROS_HOME': os.path.join(tmp, 'ros'),
           'MPLBACKEND': 'Agg'}
    if port:
        env['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    return env


def _bash(command):
    return ['bash', '-c', 'source "%s/setup.bash" && %s' % (INSTALL, command)]


def _run(command, tmp, timeout=300):
    return subprocess.run(_bash(command), env=_env(tmp), cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          universal_newlines=True, timeout=timeout)


def test_ros_finds_the_package_in_the_install_space(tmp_path):
    r = _run('rospack find rbpf_slam && rospack plugins --attrib=plugin nodelet | grep "^rbpf_slam "', str(tmp_path))
    assert r.returncode == 0, r.stdout
    lines = r.stdout.split()
    assert lines[0] == os.path.join(INSTALL, 'share', 'rbpf_slam'), r.stdout
    assert lines[-1] == os.path.join(INSTALL, 'share', 'rbpf_slam', 'nodelet_plugins.xml'), r.stdout


def test_the_install_space_holds_files_not_links_into_the_build_machine():
    links = []
    for d, dirs, names in os.walk(INSTALL):
        links += [os.path.join(d, n) for n in names + dirs if os.path.islink(os.path.join(d, n))]
    assert not links, 'symbolic links in the install space: %s' % links[:10]
    for rel in ('share/rbpf_slam/package.xml', 'share/rbpf_slam/config/fastslam.yaml',
                'share/rbpf_slam/config/fastslam_advanced.yaml', 'share/rbpf_slam/config/grid_slam_advanced.yaml',
                'share/rbpf_slam/config/worlds/paper_forest.yaml', 'share/rbpf_slam/launch/forest_demo.launch',
                'share/rbpf_slam/config/rviz/forest.rviz', 'lib/rbpf_slam/fastslam_benchmark',
                'lib/rbpf_slam/plot_forest_run', 'lib/rbpf_slam/fastslam_experiments',
                'lib/rbpf_slam/mrclam_to_bag', 'lib/rbpf_slam/victoria_park_to_bag'):
        assert os.path.isfile(os.path.join(INSTALL, rel)), rel


def test_the_offline_demo_runs_from_the_install_space(tmp_path):
    out = tmp_path / 'demo'
    r = _run('rosrun rbpf_slam fastslam_benchmark --seeds 1 --out "%s" && rosrun rbpf_slam plot_forest_run "%s" '
             '--report' % (out, out), str(tmp_path))
    assert r.returncode == 0, r.stdout[-3000:]
    assert 'paper_forest.yaml' in (out / 'summary.json').read_text()
    assert os.path.join(INSTALL, 'share') in (out / 'summary.json').read_text()
    report = (out / 'report.md').read_text()
    assert '| metric' in report and (out / 'report_paths.png').stat().st_size > 10000


def test_the_live_demo_launches_from_the_install_space(tmp_path):
    tmp = str(tmp_path)
    port = _free_port()
    launch = subprocess.Popen(_bash('exec roslaunch -p %d rbpf_slam forest_demo.launch gui:=false' % port),
                              env=_env(tmp, port), cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                              universal_newlines=True, start_new_session=True)
    try:
        script = os.path.join(tmp, 'tf_check.py')
        with open(script, 'w') as f:
            f.write(TF_CHECK)
        time.sleep(2.0)
        check = subprocess.run(_bash('python3 "%s" 60' % script), env=_env(tmp, port), cwd=tmp,
                               stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True, timeout=120)
    finally:
        os.killpg(launch.pid, signal.SIGINT)
        try:
            log, _ = launch.communicate(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(launch.pid, signal.SIGKILL)
            log, _ = launch.communicate()
    assert check.returncode == 0, 'no map -> odom from the installed demo:\n%s\n--- roslaunch:\n%s' % (
        check.stdout[-2000:], log[-4000:])
    assert 'ERROR' not in log and 'process has died' not in log, log[-4000:]


def test_the_installed_world_generators_and_experiments_run(tmp_path):
    r = _run('rosrun rbpf_slam make_dense_forest 20 3 "%s/f.trees.txt" && rosrun rbpf_slam make_stand clumped 1 '
             '"%s/c.trees.txt" && rosrun rbpf_slam fastslam_experiments --help && rosrun rbpf_slam grid_benchmark --help'
             ' && rosrun rbpf_slam lifelong_benchmark --help'
             % (tmp_path, tmp_path), str(tmp_path))
    assert r.returncode == 0, r.stdout[-3000:]
    assert len([line for line in (tmp_path / 'f.trees.txt').read_text().splitlines()
                if line and not line.startswith('#')]) == 20


def test_the_installed_trunk_extraction_runs(tmp_path):
    """extract_trunks (its script, its module and the program cloud_trunks) on a stand of make_forest_cloud."""
    r = _run('rosrun rbpf_slam extract_trunks --help > /dev/null && rosrun rbpf_slam make_forest_cloud "%s/s.pcd" '
             '--points 200000 --trees 4 --size 8 && rosrun rbpf_slam extract_trunks "%s/s.pcd"' % (tmp_path, tmp_path),
             str(tmp_path))
    assert r.returncode == 0, r.stdout[-3000:]
    assert os.path.isfile(os.path.join(INSTALL, 'lib', 'rbpf_slam', 'cloud_trunks'))
    assert (tmp_path / 's_trunks.csv').read_text().startswith('x,y,dbh,dbh_sigma,points,z_min,z_max\n')
    assert (tmp_path / 's_trunks.png').stat().st_size > 10000



def test_the_installed_tree_view_benchmark_runs(tmp_path):
    """tree_view_benchmark (its script, its module, cloud_trunks' two extractors and the installed trunk extraction
    configuration) on a stem of 30 cm, 1 cm points around and up to 5 m, on a ground of 2 cm points."""
    a, z = np.meshgrid(np.arange(94) * 2 * np.pi / 94, np.arange(0.0, 5.0, 0.01))
    gx, gy = np.meshgrid(np.arange(-1.0, 1.0, 0.02), np.arange(-1.0, 1.0, 0.02))
    xyz = np.concatenate([np.column_stack([0.15 * np.cos(a.ravel()), 0.15 * np.sin(a.ravel()), z.ravel()]),
                          np.column_stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)])]).astype('<f4')
    with open(str(tmp_path / 'stem.pcd'), 'wb') as f:
        f.write(('VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\nPOINTS %d\n'
                 'DATA binary\n' % (len(xyz), len(xyz))).encode('ascii') + xyz.tobytes())
    r = _run('rosrun rbpf_slam tree_view_benchmark --cloud "%s/stem.pcd" --stem 0,0,0.15 --distances 4 --bearings 2 '
             '--range-sigma 0 --out "%s/out"' % (tmp_path, tmp_path), str(tmp_path))
    assert r.returncode == 0, r.stdout[-3000:]
    assert os.path.isfile(os.path.join(INSTALL, 'lib', 'rbpf_slam', 'tree_view_benchmark'))
    summary = json.loads((tmp_path / 'out' / 'summary.json').read_text())
    assert summary['sweep_detector'][0]['found'] == 1.0 and summary['stem_finder'][0]['found'] == 1.0, summary


CONVERTERS = ('carmen_to_bag', 'ese650_to_bag', 'freiburg_to_bag', 'lego_to_bag', 'mrclam_to_bag',
              'victoria_park_to_bag')


def test_the_installed_converters_run(tmp_path):
    """Each converter starts from the install space (its script and its module rbpf_slam.<name> installed)."""
    r = _run(' && '.join('rosrun rbpf_slam %s --help > /dev/null' % name for name in CONVERTERS), str(tmp_path))
    assert r.returncode == 0, r.stdout[-3000:]
