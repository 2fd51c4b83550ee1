"""The offline bag runner: FastSLAM on a recorded paper-world drive, and that the truth never reaches it.

Records a bag with record_scenario, strips every ground-truth topic from a copy, runs the shared bag runner
(slam_bag --filter fastslam) on both: the outputs must be identical (extraction and filter never read the truth), and the final pose
must be near the truth and far better than dead reckoning.
"""
import filecmp
import os
import subprocess

import numpy as np
import pytest
from bagcheck import built_tool

rosbag = pytest.importorskip('rosbag')
from rbpf_slam import evaluate as ev  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WORLD = os.path.join(ROOT, 'config', 'worlds', 'paper_forest.yaml')


_tool = built_tool


def _final_xy(bag_path, topic):
    last = None
    with rosbag.Bag(bag_path) as bag:
        for _, msg, _ in bag.read_messages(topics=[topic]):
            last = msg
    return np.array([last.pose.pose.position.x, last.pose.pose.position.y])


@pytest.fixture(scope='module')
def bags(tmp_path_factory):
    d = tmp_path_factory.mktemp('firewall')
    full = str(d / 'full.bag')
    subprocess.run([_tool('record_scenario'), '--world', WORLD, '--drive', 'straight', '--seed', '3', '--out', full,
                    '--quiet'], check=True, stdout=subprocess.DEVNULL)
    stripped = str(d / 'stripped.bag')
    kept = set()
    with rosbag.Bag(full) as src, rosbag.Bag(stripped, 'w') as dst:
        for topic, msg, t in src.read_messages(raw=True):
            if topic.startswith('/ground_truth'):
                continue
            kept.add(topic)
            dst.write(topic, msg, t, raw=True)
    assert '/points' in kept and '/odom' in kept and not any(k.startswith('/ground_truth') for k in kept)
    return d, full, stripped


def _run(bag, out):
    subprocess.run([_tool('slam_bag'), '--filter', 'fastslam', '--bag', bag, '--out', out, '--seed', '3', '--quiet'],
                   check=True)
    return out


def test_truth_stripped_gives_identical_output(bags):
    d, full, stripped = bags
    a = _run(full, str(d / 'out_full'))
    b = _run(stripped, str(d / 'out_stripped'))
    for name in ('estimate.tum', 'odometry.tum', 'map.csv'):
        assert filecmp.cmp(os.path.join(a, name), os.path.join(b, name), shallow=False), name


def test_final_pose_is_near_the_truth_and_beats_dead_reckoning(bags):
    d, full, _ = bags
    out = _run(full, str(d / 'out_accuracy'))
    est = np.loadtxt(os.path.join(out, 'estimate.tum'), ndmin=2)
    truth = _final_xy(full, '/ground_truth/odom')
    odom = _final_xy(full, '/odom')
    err = np.hypot(*(est[-1, 1:3] - truth))
    dr = np.hypot(*(odom - truth))
    assert dr > 1.0, 'this seed should drift (dead reckoning %.2f m)' % dr
    assert err < 0.3, 'final error %.3f m (dead reckoning %.2f m)' % (err, dr)
    trees = ev.read_landmarks_csv(os.path.join(out, 'map.csv'))  # the evaluators' reader of the one landmark CSV
    assert 12 <= len(trees['x']) <= 20, '%d landmarks for 16 trees (14 come into the scope)' % len(trees['x'])
    assert (trees['dbh'] > 0).all() and (trees['observations'] >= 1).all()


def test_missing_bag_is_a_clear_error(tmp_path):
    for filt in ('fastslam', 'grid'):
        r = subprocess.run([_tool('slam_bag'), '--filter', filt, '--bag', str(tmp_path / 'nope.bag')],
                           stderr=subprocess.PIPE, universal_newlines=True)
        assert r.returncode == 1
        assert 'nope.bag' in r.stderr


def test_unknown_filter_is_a_usage_error(tmp_path):
    r = subprocess.run([_tool('slam_bag'), '--filter', 'gmapping', '--bag', str(tmp_path / 'x.bag')],
                       stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 2
    assert 'usage' in r.stderr


def test_laser_scan_input_on_the_lego_logs(tmp_path):
    """The runner's 2D path (--scan, per-sensor YAML) on the first 120 records of the LEGO logs, scored by
    evaluate_bag_run: it runs, writes every output, finds cylinders, and the evaluator reads them."""
    data = os.path.join(ROOT, '..', 'shared', 'data', 'brenner_lego')
    if not os.path.isdir(data):
        pytest.skip('../shared/data/brenner_lego is not present')
    bag = str(tmp_path / 'lego.bag')
    subprocess.run([_tool('lego_to_bag'), data, '-o', bag, '-q', '--limit', '120'], check=True)
    out = str(tmp_path / 'run')
    cfg = os.path.join(ROOT, 'config', 'lego')
    subprocess.run([_tool('slam_bag'), '--bag', bag, '--scan', '/scan', '--out', out, '--quiet',
                    '--extraction-config', os.path.join(cfg, 'trunk_extraction.yaml'),
                    '--config', os.path.join(cfg, 'fastslam.yaml')], check=True)
    for name in ('estimate.tum', 'odometry.tum', 'map.csv', 'timing.json'):
        assert os.path.getsize(os.path.join(out, name)) > 0, name
    subprocess.run([_tool('evaluate_bag_run'), '--bag', bag, '--run', out, '--point-offset', '0.03', '0',
                    '--quiet', '--no-plot'], check=True)
    import json
    with open(os.path.join(out, 'evaluation.json')) as f:
        ev = json.load(f)
    assert ev['map']['matched'] >= 2  # cylinders found and placed within 0.5 m of true ones
    assert ev['estimate']['path_rms'] < ev['odometry']['path_rms'] + 0.05


def test_a_missing_scan_topic_is_a_clear_error(tmp_path):
    data = os.path.join(ROOT, '..', 'shared', 'data', 'brenner_lego')
    if not os.path.isdir(data):
        pytest.skip('../shared/data/brenner_lego is not present')
    bag = str(tmp_path / 'lego.bag')
    subprocess.run([_tool('lego_to_bag'), data, '-o', bag, '-q', '--limit', '5'], check=True)
    proc = subprocess.run([_tool('slam_bag'), '--bag', bag, '--scan', '/nothing'], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, universal_newlines=True)
    assert proc.returncode == 1 and 'no topic /nothing (--scan)' in proc.stderr, proc.stderr
