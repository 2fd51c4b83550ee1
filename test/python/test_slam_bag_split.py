"""slam_bag runs grid SLAM in a process that never loads FastSLAM's libraries, and hands FastSLAM's runs on."""
import os
import subprocess

import pytest

from rbpf_slam import paths


def _program(name):
    try:
        return paths.program(name)
    except ValueError:
        pytest.skip('%s is not built' % name)


def _libraries(program):
    r = subprocess.run(['ldd', program], stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    if r.returncode != 0:
        pytest.skip('ldd cannot read %s' % program)
    return r.stdout


def test_the_grid_runner_does_not_link_pcl_or_ceres_and_the_fastslam_runner_links_pcl():
    grid = _libraries(_program('slam_bag'))
    assert 'libpcl' not in grid and 'libceres' not in grid, grid
    fastslam = _libraries(_program('slam_bag_fastslam'))
    assert 'libpcl' in fastslam


def test_a_fastslam_run_goes_to_the_fastslam_runner(tmp_path):
    # A missing bag: the error comes from the FastSLAM runner's own checks (its usage names the FastSLAM options),
    # with the exit code and message slam_bag always gave.
    r = subprocess.run([_program('slam_bag'), '--filter', 'fastslam', '--bag', str(tmp_path / 'none.bag')],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 1
    assert 'none.bag' in r.stderr and 'cannot run' not in r.stderr, r.stderr
    r = subprocess.run([_program('slam_bag'), '--help'], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True)
    assert r.returncode == 0 and '--landmarks' in r.stdout + r.stderr
