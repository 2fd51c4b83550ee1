"""rbpf_slam.soak_benchmark (scripts/soak_benchmark): the nodes it starts, memory sampling, a refused command line."""
import argparse
import os
import shutil

from rbpf_slam import soak_benchmark as sb

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_the_nodes_of_each_filter():
    grid = sb.nodes_for(argparse.Namespace(filter='grid', particles=30))
    assert grid == [('grid_slam', ['rosrun', 'rbpf_slam', 'grid_slam', '__name:=grid_slam', '_particles:=30'])]
    assert sb.nodes_for(argparse.Namespace(filter='grid', particles=0))[0][1][-1] == '__name:=grid_slam'
    fast = sb.nodes_for(argparse.Namespace(filter='fastslam', particles=0))
    assert [name for name, _ in fast] == ['trunk_extraction', 'fastslam']
    assert fast[1][1] == ['rosrun', 'rbpf_slam', 'fastslam', '__name:=fastslam']


def test_the_parameter_files_of_each_filter():
    # The package's config folder, wherever the package lies (source tree, devel or install space).
    def files(filter_name, config=None):
        pairs = sb.param_files(argparse.Namespace(filter=filter_name, config=config))
        assert all(os.path.isfile(path) for _, path in pairs), pairs
        return [(ns, os.path.basename(path)) for ns, path in pairs]
    # The advanced file first, the user's file on top, an overlay last.
    assert files('grid', os.path.join(ROOT, 'config', 'grid_single_map.yaml')) == [
        ('grid_slam', 'grid_slam_advanced.yaml'), ('grid_slam', 'grid_slam.yaml'),
        ('grid_slam', 'grid_single_map.yaml')]
    assert files('fastslam') == [('trunk_extraction', 'trunk_extraction.yaml'),
                                 ('fastslam', 'fastslam_advanced.yaml'), ('fastslam', 'fastslam.yaml')]


def test_resident_memory_of_a_process():
    assert sb.rss_mb(os.getpid()) > 1.0
    assert sb.rss_mb(2 ** 22 + 12345) is None  # above the largest pid Linux gives


def test_a_trunk_drive_needs_fastslam(capsys):
    try:
        assert sb.main(['--filter', 'grid', '--trunk-drive', 'loop']) == 1
    finally:  # the run's log folder, made before the command line is checked
        shutil.rmtree(os.path.join(os.sep + 'tmp', 'rbpf_slam_soak_%d' % os.getpid()), ignore_errors=True)
    assert capsys.readouterr().err == 'soak_benchmark: --trunk-drive goes with --filter fastslam\n'


def test_saving_the_map_needs_fastslam_and_a_period(capsys):
    # Refused before any roscore is started or folder made.
    assert sb.main(['--filter', 'grid', '--bag', 'any.bag', '--save-map-every', '60']) == 1
    assert capsys.readouterr().err == \
        'soak_benchmark: --save-map-every must be >= 0 and goes with --filter fastslam\n'
    assert sb.main(['--filter', 'fastslam', '--bag', 'any.bag', '--save-map-every', '-1']) == 1
    assert 'must be >= 0' in capsys.readouterr().err
