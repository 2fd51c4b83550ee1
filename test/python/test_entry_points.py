"""The Python entry points in scripts/ are thin: each imports main from its module of the rbpf_slam package (where
its logic lives) and exits with its code; none changes sys.path (the package is found as installed, or from a
sourced workspace, or on PYTHONPATH)."""
import importlib
import os
import re
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

#: script -> the module of the package holding its logic
MODULES = {
    'calibrate_odometry': 'calibrate',
    'converter_benchmark': 'converter_benchmark',
    'evaluate_bag_run': 'evaluate_bag_run',
    'extract_trunks': 'extract_trunks',
    'fastslam_experiments': 'fastslam_experiments',
    'grid_benchmark': 'grid_benchmark',
    'grid_buildings_benchmark': 'grid_buildings_benchmark',
    'lego_benchmark': 'lego_benchmark',
    'lifelong_benchmark': 'lifelong_benchmark',
    'make_corridor_world': 'make_corridor_world',
    'make_dense_forest': 'make_dense_forest',
    'make_forest_cloud': 'make_forest_cloud',
    'make_indoor_world': 'make_indoor_world',
    'make_stand': 'make_stand',
    'plot_forest_run': 'plot_forest_run',
    'plot_grid_run': 'plot_grid_run',
    'real_data_benchmark': 'real_data_benchmark',
    'soak_benchmark': 'soak_benchmark',
    'trajectory_eval': 'trajectory_eval',
    'tree_view_benchmark': 'tree_view_benchmark',
}

TEMPLATE = re.compile(r'#!/usr/bin/env python3\n"""[^"]+: see\s+`(\w+) --help`\s+and\s+rbpf_slam/(\w+)\.py\."""\n'
                      r'import sys\n\nfrom rbpf_slam\.(\w+) import main\n\n'
                      r"if __name__ == '__main__':\n    sys\.exit\(main\(\)\)\n\Z")


@pytest.mark.parametrize('script', sorted(MODULES))
def test_the_script_only_calls_its_module(script):
    with open(os.path.join(ROOT, 'scripts', script)) as f:
        text = f.read()
    m = TEMPLATE.match(text)
    assert m, '%s is not a thin entry point:\n%s' % (script, text)
    assert m.groups() == (script, MODULES[script], MODULES[script])
    assert 'sys.path' not in text
    module = importlib.import_module('rbpf_slam.' + MODULES[script])
    assert callable(module.main)


@pytest.mark.parametrize('module', sorted(set(MODULES.values())))
def test_no_module_changes_sys_path(module):
    with open(os.path.join(ROOT, 'src', 'rbpf_slam', module + '.py')) as f:
        assert 'sys.path' not in f.read()


def test_a_script_runs_its_module_and_passes_on_its_exit_code(tmp_path):
    """make_stand's usage error: exit code 2 and the usage naming the script as it was started."""
    script = os.path.join(ROOT, 'scripts', 'make_stand')
    r = subprocess.run([sys.executable, script, 'no_such_kind', '1', str(tmp_path / 'x.txt')],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 2 and r.stdout == ''
    assert r.stderr == 'usage: python3 %s clumped|plantation_rows|touching_pairs SEED OUT.trees.txt\n' % script
    assert not (tmp_path / 'x.txt').exists()
