"""slam_bag is one program: it runs grid SLAM without ever loading FastSLAM's libraries (PCL, Ceres), and loads
FastSLAM's runner library only for a FastSLAM run."""
import os
import subprocess

import pytest

from rbpf_slam import paths

RUNNER = 'librbpf_slam_fastslam_replay.so'


def _program(name):
    try:
        return paths.program(name)
    except ValueError:
        pytest.skip('%s is not built' % name)


def _libraries(path):
    r = subprocess.run(['ldd', path], stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    if r.returncode != 0:
        pytest.skip('ldd cannot read %s' % path)
    return r.stdout


def _run(args, **env):
    return subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                          env=dict(os.environ, **env))


def test_slam_bag_does_not_link_pcl_or_ceres_and_the_fastslam_runner_does():
    program = _program('slam_bag')
    linked = _libraries(program)
    # Ceres may be linked statically: its logging library (glog) stands for it.
    for library in ('libpcl', 'libceres', 'libglog', RUNNER):
        assert library not in linked, linked
    runner = os.path.join(os.path.dirname(os.path.dirname(program)), RUNNER)
    assert os.path.isfile(runner), runner
    runner_links = _libraries(runner)
    assert 'libpcl' in runner_links and 'libglog' in runner_links


def test_only_a_fastslam_run_loads_the_runner(tmp_path):
    not_a_bag = tmp_path / 'not_a.bag'
    not_a_bag.write_text('plain text\n')
    grid = _run([_program('slam_bag'), '--filter', 'grid', '--bag', str(not_a_bag)], LD_DEBUG='files')
    assert grid.returncode == 1 and 'not a readable bag' in grid.stderr
    for library in ('libpcl', 'libceres', 'libglog', RUNNER):
        assert library not in grid.stderr
    fastslam = _run([_program('slam_bag'), '--filter', 'fastslam', '--bag', str(not_a_bag)], LD_DEBUG='files')
    assert fastslam.returncode == 1 and 'not a readable bag' in fastslam.stderr
    assert RUNNER in fastslam.stderr and 'libpcl' in fastslam.stderr


def test_help_and_a_wrong_option_need_no_runner(tmp_path):
    r = _run([_program('slam_bag'), '--help'])
    assert r.returncode == 0 and '--landmarks' in r.stderr
    r = _run([_program('slam_bag'), '--bag', str(tmp_path / 'none.bag'), '--particles', 'many'])
    assert r.returncode == 2 and '--particles must be an integer' in r.stderr
