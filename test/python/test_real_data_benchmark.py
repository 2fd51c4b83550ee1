"""real_data_benchmark: its command line and data checks, and the table helpers on synthetic figures (no SLAM run)."""
import importlib
import math
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, 'scripts', 'real_data_benchmark')


def _load():
    return importlib.import_module('rbpf_slam.real_data_benchmark')


def _run(args, tmp_path, data_env=None):
    env = dict(os.environ)
    env.pop('RBPF_SLAM_DATA', None)
    if data_env is not None:
        env['RBPF_SLAM_DATA'] = data_env
    return subprocess.run([sys.executable, SCRIPT] + args + ['--out', str(tmp_path / 'out')], env=env,
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, timeout=60)


def test_no_data_directory_is_a_clear_error(tmp_path):
    proc = _run([], tmp_path)
    assert proc.returncode != 0
    assert 'RBPF_SLAM_DATA' in proc.stderr and '--data' in proc.stderr
    assert 'Traceback' not in proc.stderr
    assert not (tmp_path / 'out').exists()


def test_a_missing_data_directory_is_a_clear_error(tmp_path):
    missing = str(tmp_path / 'nowhere')
    for proc in (_run(['--data', missing], tmp_path), _run([], tmp_path, data_env=missing)):
        assert proc.returncode != 0
        assert missing in proc.stderr and 'Traceback' not in proc.stderr
    assert not (tmp_path / 'out').exists()


def test_missing_files_are_named(tmp_path):
    (tmp_path / 'data' / 'victoria_park').mkdir(parents=True)
    (tmp_path / 'data' / 'mrclam').mkdir()
    proc = _run(['--data', str(tmp_path / 'data'), '--only', 'vp_detections'], tmp_path)
    assert proc.returncode != 0 and 'victoria_park_ascii.zip' in proc.stderr
    proc = _run(['--data', str(tmp_path / 'data'), '--only', 'mrclam', '--robots', '2'], tmp_path)
    assert proc.returncode != 0 and 'Robot2_Odometry.dat.gz' in proc.stderr and 'Barcodes' in proc.stderr
    assert 'Robot1_' not in proc.stderr  # only the robots asked for are needed


def test_the_laser_set_does_not_ask_for_the_published_detections(tmp_path):
    rdb = _load()
    vp = tmp_path / 'data' / 'victoria_park'
    vp.mkdir(parents=True)
    (vp / 'victoria_park_ascii.zip').write_bytes(b'')
    bags = rdb.data_inputs(str(tmp_path / 'data'), ['vp_laser'], [1])
    cmd, inputs, file_name = bags['victoria_park']
    assert '--detections' not in cmd and inputs == [str(vp / 'victoria_park_ascii.zip')]
    assert file_name == 'victoria_park_laser_only'  # never reused as the bag with the detections
    with pytest.raises(rdb.DataError, match='published_measurements.dat.gz'):
        rdb.data_inputs(str(tmp_path / 'data'), ['vp_detections', 'vp_laser'], [1])
    (vp / 'published_measurements.dat.gz').write_bytes(b'')
    cmd, inputs = rdb.data_inputs(str(tmp_path / 'data'), ['vp_laser'], [1])['victoria_park']
    assert '--detections' in cmd and len(inputs) == 2  # one bag for both sets when the file is there


def test_unknown_data_set_or_robot_is_refused(tmp_path):
    proc = _run(['--data', str(tmp_path), '--only', 'vp_detections,parking_lot'], tmp_path)
    assert proc.returncode == 2 and 'parking_lot' in proc.stderr and 'vp_laser' in proc.stderr
    proc = _run(['--data', str(tmp_path), '--robots', '1,7'], tmp_path)
    assert proc.returncode == 2 and '7' in proc.stderr
    proc = _run(['--data', str(tmp_path), '--seeds', '0'], tmp_path)
    assert proc.returncode == 2


def test_only_keeps_the_table_order():
    m = _load()
    args = m.parse_args(['--data', 'x', '--only', 'mrclam,vp_detections,mrclam', '--robots', '5,1'])
    assert args.only == ['vp_detections', 'mrclam'] and args.robots == [1, 5]
    assert m.parse_args(['--data', 'x']).only == list(m.DATA_SETS)


def test_median_and_worst():
    m = _load()
    assert m.median_worst([3.0, 1.0, 2.0, None, float('nan')]) == {'median': 2.0, 'worst': 3.0, 'n': 3}
    assert m.median_worst([3, 1, 2, 10], worst='min') == {'median': 2.5, 'worst': 1.0, 'n': 4}
    assert m.median_worst([None, None]) == {'median': None, 'worst': None, 'n': 0}


def _evaluation(ate, dr, warned=None, coverage=None, matched=None):
    e = {'estimate': {'path_rms': ate}, 'odometry': {'path_rms': dr},
         'no_fit': {'estimate': {'path_rms': 2 * ate}, 'odometry': {'path_rms': 2 * dr}}, 'seconds_processing': 1.0}
    if matched is not None:
        e['map'] = {'trees': 15, 'features': matched + 2, 'matched': matched, 'duplicates': 1, 'spurious': 1}
        e['no_fit']['map'] = dict(e['map'], matched=matched - 1)
    if warned is not None:
        e['health_warned_updates'] = [warned, 100]
    if coverage is not None:
        e['coverage_95'] = {'fitted': coverage, 'no_fit': coverage / 2, 'compared': 50}
    return e


def test_figures_of_an_older_evaluation_lack_coverage_and_health():
    m = _load()
    f = m.run_figures(_evaluation(1.0, 3.0), 4.0)
    assert f['ate'] == 1.0 and f['dr_ate_no_fit'] == 6.0 and f['wall_s'] == 4.0
    assert f['coverage_fitted'] is None and f['health_share'] is None and f['matched'] is None
    f = m.run_figures(_evaluation(1.0, 3.0, warned=25, coverage=0.8, matched=12), 4.0)
    assert f['health_share'] == 0.25 and f['coverage_no_fit'] == 0.4 and f['matched_no_fit'] == 11


def _runs(m, name, ates, robot=None, **kw):
    runs = []
    for seed, ate in enumerate(ates):
        f = m.run_figures(_evaluation(ate, 10.0, warned=int(100 * ate / 20), coverage=1.0 - ate / 20, **kw), 2.0 + seed)
        f.update(set=name, robot=robot, seed=seed, failed=False, run='r%s_%d' % (robot, seed))
        runs.append(f)
    return runs


def test_table_of_victoria_park():
    m = _load()
    spec = m.DATA_SETS['vp_detections']
    runs = _runs(m, 'vp_detections', [2.0, 4.0, 8.0]) + [{'set': 'vp_detections', 'seed': 3, 'failed': True,
                                                             'error': 'slam_bag failed', 'run': 'x'}]
    table = m.set_table(runs, spec)
    rows = {r['key']: r for r in table['rows']}
    assert 'matched' not in rows and 'ate_no_fit' not in rows  # Victoria Park: no true map, GPS frame unknown
    assert rows['ate']['median'] == 4.0 and rows['ate']['worst'] == 8.0 and rows['ate']['n'] == 3
    assert rows['ate']['dead_reckoning'] == {'median': 10.0, 'worst': 10.0, 'n': 3}
    assert math.isclose(rows['coverage']['median'], 0.8) and math.isclose(rows['coverage']['worst'], 0.6)  # fitted
    assert math.isclose(rows['health_share']['worst'], 0.4)
    assert rows['wall_s']['worst'] == 4.0
    g = table['groups']
    assert g['well']['runs'] == 2 and g['badly']['runs'] == 1
    assert math.isclose(g['well']['health_warned_pooled'], (10 + 20) / 200.0)
    assert math.isclose(g['badly']['health_warned_pooled'], 0.4)
    text = m.format_table('vp_detections', spec, table, runs, 'seeds 0-3')
    assert '3 runs (seeds 0-3), 1 FAILED' in text
    assert 'ATE, rigid fit [m]' in text and '4.00' in text and '8.00' in text and '10.00' in text
    assert 'ended badly:' in text and '40 %' in text and 'landmarks' not in text


def test_table_and_robots_of_mrclam():
    m = _load()
    spec = m.DATA_SETS['mrclam_known_ids']
    runs = (_runs(m, 'mrclam_known_ids', [0.1, 0.2, 0.5], robot=1, matched=14)
            + _runs(m, 'mrclam_known_ids', [0.4, 0.6, 0.8], robot=2, matched=9))
    table = m.set_table(runs, spec)
    rows = {r['key']: r for r in table['rows']}
    assert rows['ate']['median'] == pytest.approx(0.45) and rows['ate']['worst'] == 0.8
    assert rows['ate_no_fit']['worst'] == pytest.approx(1.6) and rows['ate_no_fit']['dead_reckoning']['median'] == 20.0
    assert rows['matched']['worst'] == 9 and rows['matched']['label'] == 'landmarks matched (of 15)'
    assert rows['coverage']['worst'] == pytest.approx((1.0 - 0.8 / 20) / 2)  # no fit on MR.CLAM
    assert table['groups']['well']['runs'] == 2 and table['groups']['badly']['runs'] == 4
    robots = m.per_robot(runs, spec)
    assert robots[1]['ate'] == 0.2 and robots[1]['ended_well'] == 2 and robots[2]['ended_well'] == 0
    assert robots[2]['matched'] == 9 and robots[2]['runs'] == 3
    text = m.format_per_robot(robots)
    assert 'robot 1' in text and 'robot 2' in text and '2 of 3' in text and '0 of 3' in text


def test_the_known_ids_overlay_is_the_only_difference():
    m = _load()
    a, b = dict(m.DATA_SETS['mrclam']), dict(m.DATA_SETS['mrclam_known_ids'])
    assert not a.pop('known_ids') and b.pop('known_ids')
    a.pop('title'), b.pop('title')
    assert a == b
    assert m.KNOWN_IDS_OVERLAY.strip() == 'use_known_ids: true'
    cmd = m.slam_command(m.DATA_SETS['mrclam_known_ids'], 'b.bag', 3, 'run', 'overlay.yaml')
    assert cmd[-2:] == ['--config', 'overlay.yaml'] and cmd[cmd.index('--seed') + 1] == '3'
    assert all(os.path.isfile(cmd[i + 1]) for i, c in enumerate(cmd[:-2]) if c == '--config')


def test_every_data_set_loads_the_advanced_file_then_the_users_file_first():
    m = _load()
    for name, spec in m.DATA_SETS.items():
        assert spec['configs'][:2] == ['config/fastslam_advanced.yaml', 'config/fastslam.yaml'], name


def test_lists_and_seeds_of_the_command_line():
    m = _load()
    assert m.parse_list('3, 1,3', ['1', '2', '3'], 'robot') == ['1', '3']
    with pytest.raises(Exception, match="unknown robot 9 \\(known: 1, 2, 3\\)"):
        m.parse_list('1,9', ['1', '2', '3'], 'robot')
    assert m._seeds_text(4, 1) == 'seed 4' and m._seeds_text(0, 5) == 'seeds 0-4'
