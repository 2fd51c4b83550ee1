"""plot_forest_run on a synthetic fastslam_benchmark --out folder."""
import importlib
import json
import math
import os

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _load():
    return importlib.import_module('rbpf_slam.plot_forest_run')


def _write_run(d):
    for kind, dy in (('estimate', 0.01), ('odometry', 0.2), ('truth', 0.0)):
        with open(os.path.join(d, 'seed3_%s.tum' % kind), 'w') as f:
            for k in range(20):
                f.write('%.2f %.3f %.3f 0 0 0 0 1\n' % (0.1 * k, 0.1 * k, dy * k))
    with open(os.path.join(d, 'seed3_trees.csv'), 'w') as f:
        f.write('x,y,radius,seen\n1,2,0.2,1\n3,-2,0.15,0\n')
    with open(os.path.join(d, 'seed3_map.csv'), 'w') as f:
        f.write('id,x,y,dbh,sigma_x,sigma_y,sigma_dbh,observations,provisional\n0,1.02,2.0,0.38,0.01,0.01,0.01,9,0\n'
                '1,5,5,0.2,0.1,0.1,0.1,1,1\n')


def test_writes_a_png(tmp_path):
    _write_run(str(tmp_path))
    out = str(tmp_path / 'plot.png')
    assert _load().main([str(tmp_path), '--out', out]) == 0
    with open(out, 'rb') as f:
        assert f.read(8) == b'\x89PNG\r\n\x1a\n'


def test_empty_folder_is_an_error(tmp_path, capsys):
    assert _load().main([str(tmp_path)]) == 1
    assert 'no seed' in capsys.readouterr().err


def test_bad_tum_names_the_file(tmp_path):
    _write_run(str(tmp_path))
    with open(str(tmp_path / 'seed3_truth.tum'), 'w') as f:
        f.write('0 1 2\n')
    with pytest.raises(ValueError, match='seed3_truth.tum'):
        _load()._main([str(tmp_path)])


def test_a_map_not_in_the_landmark_csv_names_the_file(tmp_path):
    _write_run(str(tmp_path))
    with open(str(tmp_path / 'seed3_map.csv'), 'w') as f:  # the radius columns of an earlier map.csv
        f.write('id,x,y,radius,sigma_x,sigma_y,sigma_radius,observations,provisional\n0,1,2,0.2,0,0,0,9,0\n')
    with pytest.raises(ValueError, match='seed3_map.csv: not a landmark CSV'):
        _load()._main([str(tmp_path)])


def _write_summary(d, finals):
    values = ', '.join('%g' % v for v in finals)
    with open(os.path.join(d, 'summary.json'), 'w') as f:
        f.write('{"world": "/x/paper_forest.yaml", "drive": "straight", "particles": 100, "method": "circle", '
                '"first_seed": 2, "seeds": %d, "failed": 0,\n' % len(finals))
        f.write(' "final_error_m": {"median": 0.05, "worst": 0.09, "values": [%s]},\n' % values)
        f.write(' "final_error_dead_reckoning_m": {"median": 1.7, "worst": 1.2, "values": [1.7, 1.2, 2.0]},\n')
        f.write(' "tree_to_feature_m": {"median": 0.03, "worst": 0.05, "values": [0.03, 0.05, 0.02]},\n')
        f.write(' "duplicates": {"median": 0, "worst": 1, "values": [0, 1, 0]},\n')
        f.write(' "rate_hz": {"median": 150.5, "worst": 120, "values": [150.5, 120, 160]}}\n')


def _straight(n, scale=1.0, dy=0.0):
    """Poses along x, 0.1 m apart; the estimate's steps scaled by ``scale`` and offset sideways by dy * k."""
    return np.array([[0.1 * k * scale, dy * k, 0.0] for k in range(n)])


def test_rpe_of_the_truth_is_zero():
    m = _load()
    truth = _straight(50)
    t, r, pairs = m.relative_pose_error(truth.copy(), truth)
    assert (t, r) == (0.0, 0.0)
    assert pairs == 40  # pose k pairs with k + 10 (1 m of travel): 50 - 10 pairs


def test_rpe_of_a_scale_error_is_the_error_per_metre():
    m = _load()
    t, r, pairs = m.relative_pose_error(_straight(50, scale=1.1), _straight(50))
    assert t == pytest.approx(0.1, abs=1e-9)  # 10 % of each 1 m pair
    assert r == pytest.approx(0.0, abs=1e-9)
    assert pairs == 40


def test_rpe_rotation_of_a_constant_heading_error_is_zero_but_of_a_turn_is_not():
    m = _load()
    truth = _straight(30)
    est = truth.copy()
    est[:, 2] = 0.3  # a constant offset does not change relative poses' rotation
    assert m.relative_pose_error(est, truth)[1] == pytest.approx(0.0, abs=1e-9)
    est[:, 2] = np.radians(np.arange(30))  # 1 deg per step, 10 steps a pair
    assert m.relative_pose_error(est, truth)[1] == pytest.approx(10.0, abs=1e-6)


def test_rpe_without_a_pair_is_nan():
    t, r, pairs = _load().relative_pose_error(_straight(5), _straight(5))
    assert pairs == 0 and math.isnan(t) and math.isnan(r)


def test_median_seed_is_the_median_final_error():
    m = _load()
    summary = {'first_seed': 2, 'final_error_m': {'values': [0.3, 0.1, 0.2]}}
    assert m.median_seed(summary, [2, 3, 4]) == 4  # 0.2 is the median: the third seed
    assert m.median_seed(None, [3, 5]) == 3


def test_report_writes_markdown_json_and_pngs(tmp_path):
    d = str(tmp_path)
    _write_run(d)
    _write_summary(d, [0.09, 0.05, 0.07])
    with open(os.path.join(d, 'seed3_estimate.tum')) as src:
        est = src.read()
    for s in (2, 4):  # two more seeds with the same files
        for kind in ('estimate', 'odometry', 'truth'):
            with open(os.path.join(d, 'seed3_%s.tum' % kind)) as src, \
                    open(os.path.join(d, 'seed%d_%s.tum' % (s, kind)), 'w') as dst:
                dst.write(src.read())
        for kind in ('trees', 'map'):
            with open(os.path.join(d, 'seed3_%s.csv' % kind)) as src, \
                    open(os.path.join(d, 'seed%d_%s.csv' % (s, kind)), 'w') as dst:
                dst.write(src.read())
    assert est
    assert _load().main([d, '--report']) == 0
    text = open(os.path.join(d, 'report.md')).read()
    assert 'paper_forest.yaml, straight drive, 100 particles, circle extraction' in text
    assert '## Seed 4 (median final error)' in text  # 0.07 of seed 4 is the median
    assert '| final position error | 0.050 m | 0.090 m | 1.700 m (least 1.200 m) | 2.39 m |' in text
    assert '| duplicates | 0 | 1 |  | 5 |' in text
    assert 'RPE translation' in text and '--first-seed 2 --seeds 3' in text
    for name in ('report_paths.png', 'report_map.png', 'report_error.png'):
        assert '(%s)' % name in text
        with open(os.path.join(d, name), 'rb') as f:
            assert f.read(8) == b'\x89PNG\r\n\x1a\n'
    report = json.load(open(os.path.join(d, 'report.json')))
    assert report['shown_seed'] == 4
    assert report['duplicates']['worst'] == 1  # summary.json's figures are kept
    # the synthetic estimate drifts 0.01 m sideways per 0.1 m step: 0.1 m per metre of travel
    assert report['rpe_m']['median'] == pytest.approx(0.1, rel=1e-3)
    assert report['rpe_dead_reckoning_m']['median'] == pytest.approx(2.0, rel=1e-3)
    assert sorted(report['per_seed']) == ['2', '3', '4']


def test_report_without_summary_uses_the_tum_files(tmp_path):
    d = str(tmp_path)
    _write_run(d)
    assert _load().main([d, '--report', '--seed', '3']) == 0
    report = json.load(open(os.path.join(d, 'report.json')))
    assert report['final_error_m']['median'] == pytest.approx(math.hypot(0, 0.19), rel=1e-3)
    assert '## Seed 3' in open(os.path.join(d, 'report.md')).read()


def test_report_of_a_missing_seed_names_it(tmp_path):
    _write_run(str(tmp_path))
    with pytest.raises(ValueError, match='seed 9'):
        _load()._main([str(tmp_path), '--report', '--seed', '9'])


def test_figures_of_the_report_and_the_median_seed():
    m = _load()
    assert m._fmt(None) == 'n/a' and m._fmt(float('nan')) == 'n/a'
    assert m._fmt(0.0512, ' m') == '0.051 m' and m._fmt(3, digits=None) == '3' and m._fmt(0.5, ' %', 100, 1) == '50.0 %'
    summary = {'first_seed': 2, 'final_error_m': {'values': [0.3, 0.1, 0.2]}}
    assert m.median_seed(summary, [2, 3, 4]) == 4
    assert m.median_seed(None, [5, 6]) == 5
