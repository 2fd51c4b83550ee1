"""rbpf_slam.paths: the package's files from the source tree, data folders from --data or RBPF_SLAM_DATA."""
import os

import pytest

from rbpf_slam import paths

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_package_files_come_from_the_tree_the_module_is_in():
    assert os.path.samefile(paths.package_file('config', 'grid_slam.yaml'),
                            os.path.join(ROOT, 'config', 'grid_slam.yaml'))


def test_a_given_data_folder_wins_over_the_environment(monkeypatch):
    monkeypatch.setenv(paths.DATA_ENV, '/data')
    assert paths.data_dir('here', 'carmen') == 'here'
    assert paths.data_dir('', 'carmen') == os.path.join('/data', 'carmen')
    assert paths.data_dir(None) == '/data'


def test_no_data_folder_is_an_error_naming_both_ways(monkeypatch):
    monkeypatch.delenv(paths.DATA_ENV, raising=False)
    with pytest.raises(ValueError) as e:
        paths.data_dir('', 'brenner_lego')
    assert '--data' in str(e.value) and paths.DATA_ENV in str(e.value) and 'brenner_lego' in str(e.value)
