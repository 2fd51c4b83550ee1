"""plot_forest_run on a synthetic fastslam_benchmark --out folder."""
import importlib.machinery
import importlib.util
import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _load():
    path = os.path.join(ROOT, 'scripts', 'plot_forest_run')
    loader = importlib.machinery.SourceFileLoader('plot_forest_run', path)
    spec = importlib.util.spec_from_loader('plot_forest_run', loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def _write_run(d):
    for kind, dy in (('estimate', 0.01), ('odometry', 0.2), ('truth', 0.0)):
        with open(os.path.join(d, 'seed3_%s.tum' % kind), 'w') as f:
            for k in range(20):
                f.write('%.2f %.3f %.3f 0 0 0 0 1\n' % (0.1 * k, 0.1 * k, dy * k))
    with open(os.path.join(d, 'seed3_trees.csv'), 'w') as f:
        f.write('x,y,radius,seen\n1,2,0.2,1\n3,-2,0.15,0\n')
    with open(os.path.join(d, 'seed3_map.csv'), 'w') as f:
        f.write('id,x,y,radius,sigma_x,sigma_y,sigma_radius,observations,provisional\n0,1.02,2.0,0.19,0.01,0.01,0.005,9,0\n'
                '1,5,5,0.1,0.1,0.1,0.05,1,1\n')


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
        _load().main([str(tmp_path)])
