"""rviz draws each configuration of config/rviz on a short replay, under Xvfb.

For each configuration a short drive is recorded with record_scenario (forest: 12 m through the paper world;
grid: the indoor world's corridor), replayed with launch/replay.launch (forest: trunk extraction + FastSLAM;
grid: grid SLAM) with rviz on a virtual screen; once the bag has played,
a screenshot of the screen is checked: the 3D view is not blank (many distinct colours), the displays that
must have data are there (exact colours of flat displays: paths, the visibility scope, the scan; hue ranges of
lit ones: true trees, landmarks, map), and rviz logged no error. The screenshots are kept in
RBPF_WS/build/test_results/rviz_screenshots/ (one per configuration). Skipped only when rviz, Xvfb or
imagemagick's import are not installed.
"""
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WS = os.environ.get('RBPF_WS', os.path.join(ROOT, 'build'))
SHOTS = os.path.join(WS, 'build', 'test_results', 'rviz_screenshots')
IMPORT = '/usr/bin/import'  # imagemagick's, by its full path (a stand-in may come first on PATH)

_missing = [name for name, path in (('rviz', shutil.which('rviz')), ('Xvfb', shutil.which('Xvfb')),
                                    ('imagemagick import', IMPORT if os.path.exists(IMPORT) else None)) if not path]
pytestmark = pytest.mark.skipif(bool(_missing), reason='not installed: %s (apt-get install rviz xvfb imagemagick)'
                                % ', '.join(_missing))

# Colours of the flat (unlit) displays, as set in config/rviz/*.rviz (RGB 0-255). None of them is a colour of
# rviz's rainbow (one channel 0, one 255), so the lidar points cannot fake them.
TRUE_PATH = (40, 220, 40)
ESTIMATED_PATH = (40, 100, 255)
RAW_ODOMETRY = (230, 40, 40)
SCOPE = (77, 204, 255)
SCAN = (255, 40, 200)


def _tool(name):
    path = os.path.join(WS, 'devel', 'lib', 'rbpf_slam', name)
    if not os.path.exists(path):
        raise RuntimeError('%s is not built (%s); run scripts/bootstrap' % (name, path))
    return path


def _free_port():
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _start_xvfb():
    """Xvfb on a free display number (it picks one and writes it to a pipe); returns (process, ':N')."""
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(['Xvfb', '-displayfd', str(write_fd), '-screen', '0', '1280x800x24', '+extension', 'GLX',
                             '-nolisten', 'tcp'], pass_fds=(write_fd,), stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    os.close(write_fd)
    with os.fdopen(read_fd) as f:
        number = f.readline().strip()
    if not number:
        proc.kill()
        raise RuntimeError('Xvfb did not start')
    return proc, ':' + number


def _stop(proc, timeout=20.0):
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGINT)
        proc.wait(timeout)
    except (subprocess.TimeoutExpired, ProcessLookupError):
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()


# Run with the test's ROS master from the launch on: keeps in STATUS (replaced whole, never half written) how many
# messages TOPIC has carried and the wall time of the last. The SLAM node publishes its pose for every scan it
# processes, so a pose topic gone quiet after the bag has played means the node has worked through every scan that
# waited for it, however slow the machine.
_LISTEN = """
import os, sys, time
import rospy
topic, status = sys.argv[1], sys.argv[2]
rospy.init_node('caught_up_listener', anonymous=True, disable_signals=True)
heard = {'n': 0, 'last': 0.0}
def on_message(_msg):
    heard['n'] += 1
    heard['last'] = time.time()
rospy.Subscriber(topic, rospy.AnyMsg, on_message, queue_size=100)
while True:
    with open(status + '.tmp', 'w') as f:
        f.write('%d %.3f' % (heard['n'], heard['last']))
    os.replace(status + '.tmp', status)
    time.sleep(0.1)
"""


def _wait_until_caught_up(status, topic, quiet=3.0, limit=150.0):
    """Waits until TOPIC (heard by the _LISTEN process writing STATUS) has carried a message and then none for QUIET
    seconds: the SLAM node has caught up with the bag."""
    end = time.time() + limit
    n, last = 0, 0.0
    while time.time() < end:
        try:
            with open(status) as f:
                n, last = f.read().split()
            n, last = int(n), float(last)
        except (OSError, ValueError):
            n, last = 0, 0.0
        if n > 0 and time.time() - last >= quiet:
            return
        time.sleep(0.2)
    assert n > 0, 'no message on %s at all: did the SLAM node run?' % topic
    raise AssertionError('%s still carried messages %.0f s after the bag ended (%d so far)' % (topic, limit, n))


def _replay_screenshot(tmp, bag, launch_args, name, pose_topic):
    """roslaunch replay.launch with rviz on a virtual screen; a screenshot once the bag has played and the SLAM
    node has caught up (however slow the machine)."""
    xvfb, display = _start_xvfb()
    env = dict(os.environ, DISPLAY=display, ROS_MASTER_URI='http://localhost:%d' % _free_port(),
               ROS_LOG_DIR=str(tmp / 'log'), ROS_HOME=str(tmp / 'ros_home'), LIBGL_ALWAYS_SOFTWARE='1')
    env.setdefault('ROS_HOSTNAME', 'localhost')
    port = env['ROS_MASTER_URI'].rsplit(':', 1)[1]
    log_path = str(tmp / ('%s_roslaunch.log' % name))
    log = open(log_path, 'w')
    launch = subprocess.Popen(['roslaunch', '-p', port, 'rbpf_slam', 'replay.launch', 'bag:=' + bag, 'gui:=true',
                               'delay:=8'] + launch_args, env=env, stdout=log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    shot = str(tmp / (name + '.png'))
    status = str(tmp / ('%s_listener.txt' % name))
    listener = subprocess.Popen([sys.executable, '-c', _LISTEN, pose_topic, status], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.time() + 180.0
        played = False
        while time.time() < deadline and launch.poll() is None:
            with open(log_path) as f:
                text = f.read()
            if 'rosbag_play-' in text and 'process has finished cleanly' in text:
                played = True
                break
            time.sleep(1.0)
        assert played, 'the bag did not finish playing within 180 s (log: %s)' % log_path
        _wait_until_caught_up(status, pose_topic)
        time.sleep(4.0)  # rviz draws the last messages
        subprocess.run([IMPORT, '-display', display, '-window', 'root', shot], check=True, timeout=60)
    finally:
        _stop(listener)
        _stop(launch)
        log.close()
        xvfb.terminate()
        xvfb.wait()
    os.makedirs(SHOTS, exist_ok=True)
    shutil.copy(shot, os.path.join(SHOTS, name + '.png'))
    with open(log_path) as f:
        text = f.read()
    return shot, text


def _view(shot):
    """The 3D view of the screenshot (right of the Displays panel) as uint8 RGB."""
    import matplotlib.image
    image = matplotlib.image.imread(shot)
    if image.dtype != np.uint8:
        image = np.round(image * 255.0).astype(np.uint8)
    return image[60:760, 430:1270, :3].astype(np.int32)


def _count_colour(view, rgb, tolerance=12):
    return int(np.sum(np.all(np.abs(view - np.array(rgb)) <= tolerance, axis=2)))


def _distinct_colours(view):
    flat = view.reshape(-1, 3)
    return len(np.unique(flat[:, 0] * 65536 + flat[:, 1] * 256 + flat[:, 2]))


def _rviz_errors(log_text):
    # Mesa's llvmpipe refuses to link rviz's palette shader of the Map display ("active samplers with a
    # different type refer to the same texture image unit") and rviz falls back to drawing the map without it:
    # that message is not a failure of the configuration.
    return [line for line in log_text.replace('\r', '\n').splitlines()
            if ('[ERROR]' in line and 'glsl' not in line.lower()) or 'cannot launch node' in line]


def test_forest_rviz_shows_estimate_beside_truth(tmp_path):
    waypoints = tmp_path / 'drive.txt'
    waypoints.write_text('0 0\n12 0\n')
    bag = str(tmp_path / 'forest.bag')
    subprocess.run([_tool('record_scenario'), '--world', os.path.join(ROOT, 'config', 'worlds', 'paper_forest.yaml'),
                    '--drive', str(waypoints), '--seed', '1', '--out', bag, '--quiet'], check=True,
                   stdout=subprocess.DEVNULL)
    shot, log_text = _replay_screenshot(tmp_path, bag, ['slam:=fastslam'], 'forest', '/pose')
    view = _view(shot)
    assert _distinct_colours(view) > 300, 'the 3D view looks blank (%s)' % shot
    for what, rgb, least in (('true path', TRUE_PATH, 150), ('FastSLAM path', ESTIMATED_PATH, 150),
                             ('raw odometry path', RAW_ODOMETRY, 150), ('visibility scope', SCOPE, 300)):
        n = _count_colour(view, rgb)
        assert n >= least, '%s: %d pixels of %s, expected >= %d (%s)' % (what, n, rgb, least, shot)
    r, g, b = view[..., 0], view[..., 1], view[..., 2]
    brown = (r > g + 12) & (g > b + 12) & (b > 12) & (r < 230)  # lit, translucent true trunks
    green = (g > r + 40) & (g > b + 40) & (np.minimum(r, b) > 12) & (g < 240)  # lit landmark cylinders
    assert int(np.sum(brown)) >= 100, 'no true trees drawn (%s)' % shot
    assert int(np.sum(green)) >= 100, 'no landmarks drawn (%s)' % shot
    assert not _rviz_errors(log_text), 'rviz reported errors: %s' % _rviz_errors(log_text)[:3]


def test_grid_rviz_shows_map_scan_and_path(tmp_path):
    config = tmp_path / 'indoor.yaml'
    config.write_text('start: {x: 0.0, y: 0.0, yaw_deg: 0.0}\n')
    waypoints = tmp_path / 'drive.txt'
    waypoints.write_text('0 0\n8 0\n12.9 0\n12.9 5\n')  # along the south corridor, then north up the east one
    bag = str(tmp_path / 'indoor.bag')
    subprocess.run([_tool('record_scenario'), '--indoor-map', os.path.join(ROOT, 'config', 'worlds', 'indoor.yaml'),
                    '--config', str(config), '--drive', str(waypoints), '--seed', '1', '--out', bag, '--quiet'],
                   check=True, stdout=subprocess.DEVNULL)
    # Grid SLAM on the replayed bag: its map and estimated path beside the true map and path, and the scan.
    shot, log_text = _replay_screenshot(
        tmp_path, bag, ['slam:=grid', 'rviz_config:=' + os.path.join(ROOT, 'config', 'rviz', 'grid.rviz')], 'grid',
        '/pose')
    view = _view(shot)
    assert _distinct_colours(view) > 20, 'the 3D view looks blank (%s)' % shot
    for what, rgb, least in (('true path', TRUE_PATH, 100), ('estimated path', ESTIMATED_PATH, 100),
                             ('scan', SCAN, 100)):
        n = _count_colour(view, rgb)
        assert n >= least, '%s: %d pixels of %s, expected >= %d (%s)' % (what, n, rgb, least, shot)
    assert not _rviz_errors(log_text), 'rviz reported errors: %s' % _rviz_errors(log_text)[:3]
