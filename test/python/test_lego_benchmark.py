"""rbpf_slam.lego_benchmark (scripts/lego_benchmark): the table over the seeds' evaluations, and the refusal
without data."""
from rbpf_slam import lego_benchmark as lb


def _rows():
    return [{'estimate': {'path_rms': a, 'final_error': 2 * a}, 'odometry': {'path_rms': 1.0, 'final_error': 2.0},
             'map': {'mean_error': e, 'matched': m, 'duplicates': 0, 'spurious': 1}, 'seconds_processing': 0.5,
             'coverage_95': {'fitted': c, 'no_fit': 0.5, 'compared': 100}}
            for a, m, e, c in ((0.01, 7, 0.01, 0.9), (0.03, 9, None, 0.2), (0.02, 8, 0.02, 0.5))]


def test_the_table_and_the_summary():
    lines, summary = lb.report('logs', _rows())
    assert lines == [
        'LEGO logs (logs), 3 seeds, scanner point after a least-squares rigid fit onto the reference',
        '                          median     worst   raw odometry',
        'path RMS [mm]               20.0      30.0         1000.0',
        'final error [mm]            40.0      60.0         2000.0',
        'landmark error [mm]         15.0      20.0               ',
        'true landmarks found         8.0       7.0               ',  # the worst is the fewest found
        'duplicates                   0.0       0.0               ',
        'spurious                     1.0       1.0               ',
        'truth in 95% region %       50.0      20.0               ',  # the worst is the least covered
        'processing [ms]            500.0     500.0               ']
    assert summary['seeds'] == 3 and len(summary['runs']) == 3
    assert summary['path RMS [mm]'] == {'median': 20.0, 'worst': 30.0, 'odometry': 1000.0}
    assert summary['true landmarks found'] == {'median': 8.0, 'worst': 7.0, 'odometry': None}


def test_no_data_directory_is_exit_code_2(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv('RBPF_SLAM_DATA', raising=False)
    assert lb.main(['--out', str(tmp_path / 'out')]) == 2
    assert capsys.readouterr().err == 'lego_benchmark: no data directory: give --data DIR or set RBPF_SLAM_DATA\n'
    assert not (tmp_path / 'out').exists()
