"""rbpf_slam.converter_benchmark (scripts/converter_benchmark): its table, and the refusal without data."""
import os
import subprocess
import sys

from rbpf_slam import converter_benchmark as cb

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_the_table():
    lines = cb.table([('CARMEN Intel (whole log)', 2691.0, 10.0, 12.5e6), ('ESE 650 run 20 (encoders, IMU)', 45.04, 0.5,
                                                                           1.25e6)])
    assert lines == [
        'log                                        span [s]  convert [s]  x real time  bag [MB]',
        'CARMEN Intel (whole log)                     2691.0        10.00          269      12.5',
        'ESE 650 run 20 (encoders, IMU)                 45.0         0.50           90       1.2',
        '(wall-clock time of each command, Python start-up included; x real time = span / convert)']


def test_the_converters_it_times_are_the_package_entry_points():
    for name in ('carmen_to_bag', 'ese650_to_bag'):
        assert os.path.samefile(cb._script(name), os.path.join(ROOT, 'scripts', name))


def test_no_data_directory_is_exit_code_2(capsys, monkeypatch):
    monkeypatch.delenv('RBPF_SLAM_DATA', raising=False)
    assert cb.main([]) == 2
    assert capsys.readouterr().err == ('converter_benchmark: no data directory: give --data DIR or set '
                                       'RBPF_SLAM_DATA\n')


def test_a_missing_log_is_named(tmp_path):
    r = subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', 'converter_benchmark'), '--data', str(tmp_path)],
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert r.returncode == 1
    assert r.stderr == 'converter_benchmark: missing %s\n' % os.path.join(str(tmp_path), 'carmen',
                                                                         'intel-corrected.log.gz')
