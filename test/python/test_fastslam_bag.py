"""The offline bag runner: FastSLAM on a recorded paper-world drive, and that the truth never reaches it.

Records a bag with record_scenario, strips every ground-truth topic from a copy, runs the shared bag runner
(slam_bag --filter fastslam) on both: the outputs must be identical (extraction and filter never read the truth), and the final pose
must be near the truth and far better than dead reckoning.
"""
import csv
import filecmp
import json
import os
import subprocess

import numpy as np
import pytest
from bagcheck import DATA, built_tool

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
    d = tmp_path_factory.mktemp('truth_stripped')
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
    data = os.path.join(DATA, 'brenner_lego')
    if not os.path.isdir(data):
        pytest.skip('%s is not present' % data)
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
    data = os.path.join(DATA, 'brenner_lego')
    if not os.path.isdir(data):
        pytest.skip('%s is not present' % data)
    bag = str(tmp_path / 'lego.bag')
    subprocess.run([_tool('lego_to_bag'), data, '-o', bag, '-q', '--limit', '5'], check=True)
    proc = subprocess.run([_tool('slam_bag'), '--bag', bag, '--scan', '/nothing'], stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, universal_newlines=True)
    assert proc.returncode == 1 and 'no topic /nothing (--scan)' in proc.stderr, proc.stderr


def test_fastslam2_repeats_byte_for_byte(bags, tmp_path):
    """The same seed gives the same output, FastSLAM 2.0 included (its proposal conditions on the matched trunks
    with floating-point arithmetic whose order is fixed)."""
    d, full, _ = bags
    config = str(tmp_path / 'fastslam2.yaml')
    with open(os.path.join(ROOT, 'config', 'fastslam.yaml')) as src, open(config, 'w') as dst:
        text = src.read()
        assert 'proposal: fastslam1' in text
        dst.write(text.replace('proposal: fastslam1', 'proposal: fastslam2'))
    advanced = os.path.join(ROOT, 'config', 'fastslam_advanced.yaml')
    outs = []
    for k in range(2):
        out = str(tmp_path / ('run%d' % k))
        subprocess.run([_tool('slam_bag'), '--filter', 'fastslam', '--bag', full, '--config', advanced,
                        '--config', config, '--out', out, '--seed', '5', '--quiet'], check=True)
        outs.append(out)
    for name in ('estimate.tum', 'estimate_best_history.tum', 'odometry.tum', 'updates.csv', 'map.csv'):
        assert filecmp.cmp(os.path.join(outs[0], name), os.path.join(outs[1], name), shallow=False), name


def test_run_folder_has_the_online_estimate_best_history_and_update_statistics(bags):
    d, full, _ = bags
    out = _run(full, str(d / 'out_files'))
    est = np.loadtxt(os.path.join(out, 'estimate.tum'), ndmin=2)
    hist = np.loadtxt(os.path.join(out, 'estimate_best_history.tum'), ndmin=2)
    # One pose per update of the filter, at its stamp: every sweep but those that waited for a new view (fused into
    # the next), which the run's updates.csv shows without a particle cloud.
    with open(os.path.join(out, 'updates.csv')) as f:
        filtered = [line.strip().split(',')[14] != '' for line in list(f)[1:]]
    assert len(filtered) == len(est) and sum(filtered) >= len(est) // 2
    assert hist.shape == (sum(filtered), 8) and (hist[:, 0] == est[np.array(filtered), 0]).all()
    # The online estimate moves smoothly: no step between updates longer than the robot drives in one (0.1 m)
    # plus a few centimetres, even where the filter resampled.
    steps = np.hypot(*np.diff(est[:, 1:3], axis=0).T)
    assert steps.max() < 0.2, 'the estimate jumps by %.2f m' % steps.max()
    with open(os.path.join(out, 'updates.csv')) as f:
        header = f.readline().strip().split(',')
        rows = [line.strip().split(',') for line in f]
    assert header == ['stamp', 'neff', 'resampled', 'landmarks', 'observations', 'matched', 'new', 'deleted',
                      'ignored', 'matched_confirmed', 'recreated', 'pose_spread', 'relocalizing', 'health',
                      'cloud_x', 'cloud_y', 'cloud_xx', 'cloud_xy', 'cloud_yy', 'loop', 'estimate_x', 'estimate_y',
                      'estimate_xx', 'estimate_xy', 'estimate_yy', 'health_cause']
    assert len(rows) == len(est)
    # Every warning names its cause; an update that does not warn names none.
    assert all(r[25] in ('none', 'recreated', 'unmatched', 'inconsistent', 'overconfident', 'saved_map_unobserved')
               for r in rows)
    assert all((r[13] == 'ok') == (r[25] == 'none') for r in rows)
    # The published estimate's region: its position is the estimate's, its covariance positive definite.
    region = np.array([[float(v) for v in r[20:25]] for r in rows if r[22] != ''])
    assert len(region) >= len(est) // 2
    assert np.allclose(region[:, 0:2], est[[i for i, r in enumerate(rows) if r[22] != ''], 1:3], atol=1e-6)
    assert ((region[:, 2] > 0) & (region[:, 4] > 0) & (region[:, 2] * region[:, 4] > region[:, 3] ** 2)).all()
    neff = np.array([float(r[1]) for r in rows if r[14] != ''])  # the filter's updates
    assert len(neff) == len(hist) and ((neff > 0) & (neff <= 100.0 + 1e-9)).all()
    assert int(rows[-1][3]) == len(ev.read_landmarks_csv(os.path.join(out, 'map.csv'))['x'])


def test_landmark_detections_of_any_detector(tmp_path):
    """slam_bag --landmarks reads a detector's TrunkArrays (a data set's range-bearing observations, unknown
    association): every landmark is found once."""
    from bagcheck import data_path
    from rbpf_slam import convert_common as cc
    from rbpf_slam import freiburg
    d = os.path.dirname(data_path('freiburg_course', 'sensor_data.dat'))
    bag = str(tmp_path / 'freiburg.bag')
    cc.convert_to_bag(freiburg.convert, freiburg.build_parser().parse_args([d, '-o', bag, '--quiet']))
    out = str(tmp_path / 'run')
    subprocess.run([_tool('slam_bag'), '--filter', 'fastslam', '--bag', bag, '--landmarks', '/landmarks',
                    '--config', os.path.join(ROOT, 'config', 'fastslam_advanced.yaml'),
                    '--config', os.path.join(ROOT, 'config', 'fastslam.yaml'), '--seed', '1', '--out', out, '--quiet'],
                   check=True)
    est = np.loadtxt(os.path.join(out, 'estimate.tum'), ndmin=2)
    assert len(est) == 332
    m = ev.read_landmarks_csv(os.path.join(out, 'map.csv'))
    truth = [(2, 1), (0, 4), (2, 7), (9, 2), (10, 5), (9, 8), (5, 5), (5, 3), (5, 9)]
    confirmed = [(x, y) for x, y, p in zip(m['x'], m['y'], m['provisional']) if not p]
    assert len(confirmed) == 9, confirmed
    for tx, ty in truth:  # without a fit: the map frame is the start pose, which drifts a little over the run
        assert min(np.hypot(x - tx, y - ty) for x, y in confirmed) < 1.0, (tx, ty)
    # --landmarks with a 2D scan topic is a usage error
    r = subprocess.run([_tool('slam_bag'), '--bag', bag, '--landmarks', '/landmarks', '--scan', '/scan'],
                       capture_output=True, text=True)
    assert r.returncode != 0 and '--landmarks goes with' in r.stderr


def _viewpoints(path):
    """The '# viewpoint:' lines of a tree map file as dicts of floats."""
    out = []
    with open(path) as f:
        for line in f:
            if line.startswith('# viewpoint:'):
                out.append({k: float(v) for k, v in (item.split('=') for item in line.split(':', 1)[1].split())})
    return out


def test_a_saved_map_is_read_back_and_the_second_visit_keeps_its_trees(bags, tmp_path):
    """--save-map writes the tree map file (ids, covariance, first and last seen); --map starts a second run of the
    same drive from it: the trees are matched rather than made again, and the pose stays as good."""
    _, full, _ = bags
    first = str(tmp_path / 'forest_map.csv')
    subprocess.run([_tool('slam_bag'), '--bag', full, '--seed', '3', '--quiet', '--save-map', first], check=True)
    saved = ev.read_landmarks_csv(first)
    assert saved['anchor'] is None
    confirmed = ~saved['provisional']
    assert confirmed.sum() >= 12
    assert np.isfinite(saved['first_seen']).all() and (saved['last_seen'] >= saved['first_seen']).all()
    assert (saved['cov_xy'] ** 2 <= (saved['sigma_x'] * saved['sigma_y']) ** 2 + 1e-12).all()
    # Where the map was looked at from: one viewpoint per metre of ground, with the lidar's all-round scope.
    viewpoints = _viewpoints(first)
    assert 20 <= len(viewpoints) <= 40, len(viewpoints)  # the drive: 30 m straight
    assert all(v['fov_max'] - v['fov_min'] > 6.28 and 0.0 < v['min_range'] < v['max_range'] for v in viewpoints)
    assert max(v['x'] for v in viewpoints) > 20.0

    out = str(tmp_path / 'second')
    again = str(tmp_path / 'forest_map_2.csv')
    r = subprocess.run([_tool('slam_bag'), '--bag', full, '--seed', '4', '--map', first, '--initial-pose', '0', '0',
                        '0', '--out', out, '--save-map', again], stdout=subprocess.PIPE, universal_newlines=True,
                       check=True)
    assert 'starting from %s' % first in r.stdout
    second = ev.read_landmarks_csv(again)
    kept = set(saved['id'][confirmed])
    assert kept <= set(second['id']), 'every confirmed tree of the first visit is still in the map'
    # A tree made again would be confirmed (every tree of this world was confirmed on the first visit) or stand where
    # a confirmed tree stood; a landmark seen once or twice where nothing was (clutter) stays provisional.
    new = [k for k, i in enumerate(second['id']) if i not in set(saved['id'])]
    made_again = [int(second['id'][k]) for k in new if not second['provisional'][k]]
    assert made_again == [], 'trees made again instead of matched: %s' % made_again
    trees = np.column_stack([saved['x'][confirmed], saved['y'][confirmed]])
    for k in new:
        gap = np.hypot(trees[:, 0] - second['x'][k], trees[:, 1] - second['y'][k]).min()
        assert gap > 1.0, 'landmark %d made again %.2f m from a tree of the first visit' % (second['id'][k], gap)
        assert second['observations'][k] <= 2, 'new landmark %d seen %d times' % (second['id'][k],
                                                                             second['observations'][k])
    # The same ground driven again adds no viewpoint: the map does not grow with visits to the same place.
    assert abs(len(_viewpoints(again)) - len(viewpoints)) <= 3
    back = {i: k for k, i in enumerate(second['id'])}
    for k, i in enumerate(saved['id']):
        if i in back and confirmed[k]:
            assert second['observations'][back[i]] > saved['observations'][k]
            assert second['first_seen'][back[i]] == pytest.approx(saved['first_seen'][k])
    est = np.loadtxt(os.path.join(out, 'estimate.tum'), ndmin=2)
    err = np.hypot(*(est[-1, 1:3] - _final_xy(full, '/ground_truth/odom')))
    assert err < 0.3, 'final error %.3f m in the saved map' % err


def test_a_bad_map_file_is_one_line_and_nothing_is_written(bags, tmp_path):
    _, full, _ = bags
    bad = tmp_path / 'bad.csv'
    bad.write_text('id,x,y,dbh\n1,2,nan,0.3\n')
    out = tmp_path / 'run'
    r = subprocess.run([_tool('slam_bag'), '--bag', full, '--map', str(bad), '--out', str(out)],
                       stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 1
    assert 'bad.csv:2: expected a finite number for y' in r.stderr and 'Traceback' not in r.stderr
    assert not out.exists()
    r = subprocess.run([_tool('slam_bag'), '--bag', full, '--initial-pose', '1', '2', '3'],
                       stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 2 and '--initial-pose goes with --map' in r.stderr


def _compose(a, b):
    c, s = np.cos(a[2]), np.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def test_the_start_is_found_in_a_saved_map_and_an_unknown_stand_is_refused(tmp_path):
    """Visit 2 starts elsewhere in the paper world, heading elsewhere, with no start pose given: slam_bag --map finds
    it from the trunks (constellation search) and tracks in the saved map's frame. The same search in another stand's
    map finds nothing and writes nothing."""
    saved = os.path.join(ROOT, 'test', 'ros', 'paper_forest_map.csv')  # frame: the default start (0, 15), east
    drive = tmp_path / 'drive.txt'
    drive.write_text('5 0\n10 0\n')
    bag = str(tmp_path / 'visit2.bag')
    subprocess.run([_tool('record_scenario'), '--world', WORLD, '--drive', str(drive), '--seed', '5', '--start', '25',
                    '20', '200', '--out', bag, '--quiet'], check=True, stdout=subprocess.DEVNULL)
    out = str(tmp_path / 'run')
    anchored = tmp_path / 'anchored_map.csv'  # the same map placed on the earth
    with open(saved) as f:
        anchored.write_text('# anchor: latitude=61.5 longitude=24.25 altitude=100 yaw=0.3 sigma=1\n' + f.read())
    changes, after = str(tmp_path / 'after_changes'), str(tmp_path / 'after.csv')  # the changes beside the map
    r = subprocess.run([_tool('slam_bag'), '--bag', bag, '--map', str(anchored), '--out', out,
                        '--save-map', after], stdout=subprocess.PIPE, universal_newlines=True, check=True)
    assert 'the start pose searched from the trunks seen' in r.stdout
    # Nothing changed in this stand: no tree is felled; the files a GIS reads are valid GeoJSON in WGS84.
    with open(changes + '.csv') as f:
        rows = list(csv.DictReader(f))
    assert [row['kind'] for row in rows].count('felled') == 0, rows
    for path in (changes + '.geojson', str(tmp_path / 'after.geojson')):
        with open(path) as f:
            doc = json.load(f)
        assert doc['type'] == 'FeatureCollection'
        for feature in doc['features']:
            assert feature['type'] == 'Feature' and feature['geometry']['type'] == 'Point'
            lon, lat = feature['geometry']['coordinates']
            assert abs(lon - 24.25) < 0.001 and abs(lat - 61.5) < 0.001, (lon, lat)
    trees = json.load(open(str(tmp_path / 'after.geojson')))['features']
    assert len(trees) >= 14 and all(t['properties']['dbh_m'] > 0 for t in trees)
    assert ev.read_landmarks_csv(after)['anchor']['latitude'] == 61.5  # the anchor is kept
    assert 'relocalized in the saved map' in r.stdout, r.stdout
    stamps, xy, _ = ev.read_tum(os.path.join(out, 'estimate.tum'))
    truth = []
    with rosbag.Bag(bag) as b:
        for _, msg, _ in b.read_messages(topics=['/ground_truth/odom']):
            p = msg.pose.pose.position
            truth.append((msg.header.stamp.to_sec(), p.x, p.y))
    to_map = _compose((0.0, -15.0, 0.0), (25.0, 20.0, np.radians(200.0)))
    errors = []
    for t, (x, y) in zip(stamps, xy):
        k = int(np.argmin([abs(s - t) for s, _, _ in truth]))
        px, py, _ = _compose(to_map, (truth[k][1], truth[k][2], 0.0))
        errors.append(np.hypot(x - px, y - py))
    assert len(errors) > 50 and max(errors) < 0.3, 'errors in the saved map: first %.3f, max %.3f m' % (
        errors[0], max(errors))

    other = tmp_path / 'other_map.csv'  # the trees of another stand
    clumped = os.path.join(ROOT, 'config', 'worlds', 'clumped.trees.txt')
    rows = [line.split() for line in open(clumped) if line.strip() and not line.startswith('#')]
    other.write_text('id,x,y,dbh\n' + ''.join('%d,%s,%s,%.3f\n' % (i, r[0], r[1], 2 * float(r[2]))
                                               for i, r in enumerate(rows)))
    refused = str(tmp_path / 'refused')
    r = subprocess.run([_tool('slam_bag'), '--bag', bag, '--map', str(other), '--out', refused],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 1
    assert 'not relocalized in the saved map' in r.stderr and 'nothing written' in r.stderr, r.stderr
    assert not os.path.exists(refused)


def test_satellite_fixes_anchor_a_new_map_on_the_earth(tmp_path):
    """A drive with the simulator's receiver (world heading 30 deg from east): the saved map gains an anchor fitted to
    the fixes, within three of its stated sigmas of the truth, and a GeoJSON beside it; --no-gps leaves the map local;
    a --gps topic the bag lacks is a clear error."""
    sim = tmp_path / 'sim.yaml'
    sim.write_text('gps: {enabled: true, world_yaw_deg: 30.0, origin: {latitude: 61.5, longitude: 24.25, '
                   'altitude: 100.0}}\n')
    bag = str(tmp_path / 'gps.bag')
    subprocess.run([_tool('record_scenario'), '--world', WORLD, '--drive', 'loop', '--seed', '4', '--config', str(sim),
                    '--out', bag, '--quiet'], check=True, stdout=subprocess.DEVNULL)
    saved = str(tmp_path / 'map.csv')
    r = subprocess.run([_tool('slam_bag'), '--bag', bag, '--seed', '4', '--save-map', saved],
                       stdout=subprocess.PIPE, universal_newlines=True, check=True)
    assert 'fitted to the fixes' in r.stdout, r.stdout
    anchor = ev.read_landmarks_csv(saved)['anchor']
    assert anchor is not None
    # The map frame is the start (0, 15, 0) of the world: its origin lies 15 m along the world's y axis, which
    # points 120 deg from east; its x axis points 30 deg from east.
    lat0 = np.radians(61.5)
    e2 = (1.0 / 298.257223563) * (2.0 - 1.0 / 298.257223563)
    w = np.sqrt(1.0 - e2 * np.sin(lat0) ** 2)
    meridian, parallel = 6378137.0 * (1.0 - e2) / w ** 3 + 100.0, (6378137.0 / w + 100.0) * np.cos(lat0)
    east = np.radians(anchor['longitude'] - 24.25) * parallel
    north = np.radians(anchor['latitude'] - 61.5) * meridian
    true_east, true_north = 15.0 * np.cos(np.radians(120.0)), 15.0 * np.sin(np.radians(120.0))
    error = np.hypot(east - true_east, north - true_north)
    assert 0.0 < anchor['sigma'] < 5.0
    assert error < 3.0 * anchor['sigma'] + 0.5, 'origin %.2f m off, stated sigma %.2f m' % (error, anchor['sigma'])
    assert abs(np.degrees(anchor['yaw']) - 30.0) < 10.0, np.degrees(anchor['yaw'])
    doc = json.load(open(str(tmp_path / 'map.geojson')))
    assert doc['type'] == 'FeatureCollection' and len(doc['features']) >= 10

    def with_wild_fixes(name, wild):
        """The bag with the valid fixes whose index is wild(k) moved ~1000 km north; slam_bag's output and anchor."""
        path = str(tmp_path / (name + '.bag'))
        with rosbag.Bag(bag) as src, rosbag.Bag(path, 'w') as dst:
            k = 0
            for topic, msg, t in src.read_messages():
                if topic == '/gps/fix' and msg.status.status >= 0:
                    if wild(k):
                        msg.latitude += 9.0  # ~1000 km north
                    k += 1
                dst.write(topic, msg, t)
        saved = str(tmp_path / (name + '.csv'))
        r = subprocess.run([_tool('slam_bag'), '--bag', path, '--seed', '4', '--save-map', saved],
                           stdout=subprocess.PIPE, universal_newlines=True, check=True)
        a = ev.read_landmarks_csv(saved)['anchor']
        east = np.radians(a['longitude'] - 24.25) * parallel
        north = np.radians(a['latitude'] - 61.5) * meridian
        return r.stdout, a, np.hypot(east - true_east, north - true_north)

    # Ten fixes in a row 1000 km away (a receiver's fault): the gate and the robust fit leave them out, and the
    # anchor stays where the good fixes put it.
    _, a, error = with_wild_fixes('wild', lambda k: 40 <= k < 50)
    assert 0.0 < a['sigma'] < 5.0, a
    assert error < 3.0 * a['sigma'] + 0.5, 'with wild fixes: origin %.2f m off, sigma %.2f m' % (error, a['sigma'])
    assert abs(np.degrees(a['yaw']) - 30.0) < 10.0, np.degrees(a['yaw'])

    # The receiver's first 20 fixes 1000 km north, before any anchor exists: the first anchor is theirs, and its gate
    # refuses the good fixes after them; the robust fit follows the good ones once they are the more.
    out, a, error = with_wild_fixes('first_wild', lambda k: k < 20)
    assert '20 satellite fixes were left out of the anchor' in out, out
    assert 0.0 < a['sigma'] < 5.0, a
    assert error < 3.0 * a['sigma'] + 0.5, 'first 20 fixes wild: origin %.2f m off, sigma %.2f m' % (error, a['sigma'])

    local = str(tmp_path / 'local.csv')
    subprocess.run([_tool('slam_bag'), '--bag', bag, '--seed', '4', '--save-map', local, '--no-gps', '--quiet'],
                   check=True)
    assert ev.read_landmarks_csv(local)['anchor'] is None and not os.path.exists(str(tmp_path / 'local.geojson'))
    r = subprocess.run([_tool('slam_bag'), '--bag', bag, '--gps', '/fix', '--save-map', str(tmp_path / 'x.csv')],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode != 0 and '--gps' in r.stderr and '/fix' in r.stderr, r.stderr
    assert not os.path.exists(str(tmp_path / 'x.csv'))
