"""rbpf_slam.grid_benchmark (scripts/grid_benchmark): seeds, the summary statistics and the table rows (the runs
themselves: test_grid_slam_bag.py)."""
import os

import pytest

from rbpf_slam import grid_benchmark as gb


def test_the_default_configs_are_the_shipped_filter_advanced_file_first():
    configs = gb.default_configs()
    assert [os.path.basename(c) for c in configs] == ['grid_slam_advanced.yaml', 'grid_slam.yaml']
    assert all(os.path.isfile(c) for c in configs)


def test_seeds():
    assert gb.parse_seeds('0-3') == [0, 1, 2, 3]
    assert gb.parse_seeds('0,3,5') == [0, 3, 5]
    assert gb.parse_seeds('1-2,7') == [1, 2, 7]
    with pytest.raises(ValueError):
        gb.parse_seeds('a')


def test_median_and_worst_leave_out_missing_figures():
    assert gb.median([3.0, None, 1.0, 2.0]) == 2.0
    assert gb.median([4.0, 1.0, 3.0, 2.0]) == 2.5
    assert gb.median([None]) is None
    assert gb.worst([0.5, None, 2.5, 1.0]) == 2.5 and gb.worst([]) is None


def test_a_row():
    assert gb.row('seed 1', {'ate': 0.1234, 'wall': 12.34, 'rss': 99.6}) == (
        'seed 1                       0.123           -           -           -        12.3           -         100'
        '           -')
    assert gb.row('odometry', {}) == 'odometry' + ' ' * 14 + '           -' * len(gb.COLUMNS)
