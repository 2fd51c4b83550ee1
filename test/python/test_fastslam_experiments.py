"""fastslam_experiments with a stand-in for fastslam_benchmark: worlds, tables, plot."""
import importlib
import json
import os
import stat

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

FAKE = r'''#!/usr/bin/env python3
# Stand-in for fastslam_benchmark: one summary.json per variant; error falls with particles, rises with trees.
import json, os, sys
a = dict(zip(sys.argv[1::2], sys.argv[2::2]))
parts = [int(p) for p in a['--particles'].split(',')]
methods = a['--method'].split(',')
with open(a['--world']) as f:
    trees_line = [l for l in f if l.startswith('trees:')][0]
n = 16 if 'paper' in trees_line else int(trees_line.split('forest_')[1].split('.')[0])
for m in methods:
    for p in parts:
        d = a['--out'] if len(parts) * len(methods) == 1 else os.path.join(a['--out'], '%s_%s_p%d' % (a['--proposal'], m, p))
        os.makedirs(d, exist_ok=True)
        e = 0.01 * n / p ** 0.5
        st = lambda v: {'median': v, 'worst': 2 * v, 'values': [v]}
        json.dump({'first_seed': int(a['--first-seed']), 'seeds': int(a['--seeds']), 'failed': 0,
                   'final_error_m': st(e), 'final_error_dead_reckoning_m': st(1.6), 'ate_m': st(e / 2),
                   'ate_dead_reckoning_m': st(0.8), 'filter_rate_hz': st(1e5 / p), 'rate_hz': st(200.0)},
                  open(os.path.join(d, 'summary.json'), 'w'))
'''


def _load():
    return importlib.import_module('rbpf_slam.fastslam_experiments')


def test_world_has_the_paper_settings_and_n_trees(tmp_path):
    world = _load().write_world(50, str(tmp_path))
    with open(world) as f:
        text = f.read()
    assert 'ground:' in text and 'forest_50.trees.txt' in text
    with open(os.path.join(str(tmp_path), 'forest_50.trees.txt')) as f:
        assert len([l for l in f if l.strip() and not l.startswith('#')]) == 50


def test_tables_and_plot_from_the_benchmark_summaries(tmp_path):
    fake = tmp_path / 'fake_benchmark'
    fake.write_text(FAKE)
    fake.chmod(fake.stat().st_mode | stat.S_IXUSR)
    out = str(tmp_path / 'out')
    assert _load().main(['--out', out, '--bin', str(fake), '--seeds', '2', '--particles', '5,100,1000',
                         '--trees', '50,200']) == 0
    with open(os.path.join(out, 'experiments.md')) as f:
        table = f.read()
    # 3 particle counts and 3 stands (16, 50, 200), each with both extraction methods.
    rows = [l for l in table.splitlines() if l.startswith('| ') and l[2].isdigit()]
    assert len(rows) == 2 * 3 + 2 * 3
    assert '| 1000 | circle | 0.005 / 0.010 | 1.600 / 3.200 |' in table
    with open(os.path.join(out, 'experiments.png'), 'rb') as f:
        assert f.read(8) == b'\x89PNG\r\n\x1a\n'
    with open(os.path.join(out, 'experiments.json')) as f:
        data = json.load(f)
    assert data['trees']['centroid_t200']['final_error_m']['median'] > data['trees']['centroid_t16']['final_error_m']['median']


def test_a_table_row_and_the_summaries_it_reads(tmp_path):
    m = _load()
    st = lambda v: {'median': v, 'worst': 2 * v}  # noqa: E731
    s = {'final_error_m': st(0.1), 'final_error_dead_reckoning_m': st(1.6), 'ate_m': st(0.05),
         'ate_dead_reckoning_m': st(0.8), 'filter_rate_hz': st(1000.0), 'rate_hz': st(200.0), 'failed': 1, 'seeds': 3}
    assert m.row('100', 'circle', s) == ('| 100 | circle | 0.100 / 0.200 | 1.600 / 3.200 | 0.050 / 0.100 | 0.800 / 1.600 '
                                         '| 1000 / 2000 | 200 / 400 | 1 of 3 |')
    assert (m.HEADER % 'trees').count('|---') == 9
    for sub, v in (('fastslam1_circle_p5', 1.0), ('fastslam1_circle_p50', 2.0)):
        (tmp_path / sub).mkdir()
        (tmp_path / sub / 'summary.json').write_text(json.dumps({'v': v}))
    assert m.read_summaries(str(tmp_path), [5, 50], ['circle'], 'fastslam1') == {('circle', 5): {'v': 1.0},
                                                                                ('circle', 50): {'v': 2.0}}
    (tmp_path / 'summary.json').write_text('{"v": 3.0}')  # a single variant writes into the folder itself
    assert m.read_summaries(str(tmp_path), [5], ['circle'], 'fastslam1') == {('circle', 5): {'v': 3.0}}
