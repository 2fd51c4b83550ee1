"""rbpf_slam.tree_view_benchmark (scripts/tree_view_benchmark): the virtual lidar on a cylinder whose view is known
(one return per beam, the side facing the sensor only, every ring), the benchmark finding the cylinder with both
extractors, and its command line; on the data folder's TreeLS trees when RBPF_SLAM_DATA is set."""
import json
import os
import subprocess

import numpy as np
import pytest

from rbpf_slam import extract_trunks, paths
from rbpf_slam import tree_view_benchmark as tvb

STEM = (0.4, -0.2, 0.15)  # x, y, radius [m]
GROUND = 0.1  # [m]


def cylinder_cloud(hole=False):
    """A stem of 30 cm on flat ground, on a 1 cm grid as a voxelized terrestrial scan holds it: the stem's points 1 cm
    apart around and up (0-6 m), the ground's 1 cm apart within 1.5 m of the axis. With ``hole`` the scan missed a
    patch 20 cm wide and 40 cm tall of the stem's side towards +x at 1.1-1.5 m."""
    x, y, r = STEM
    n = int(round(2 * np.pi * r / 0.01))
    a, z = np.meshgrid(np.arange(n) * 2 * np.pi / n, np.arange(0.0, 6.0, 0.01))
    stem = np.column_stack([x + r * np.cos(a.ravel()), y + r * np.sin(a.ravel()), GROUND + z.ravel()])
    if hole:
        stem = stem[~((stem[:, 0] - x > 0.1) & (np.abs(stem[:, 1] - y) < 0.1) &
                      (stem[:, 2] > GROUND + 1.1) & (stem[:, 2] < GROUND + 1.5))]
    g = np.arange(-1.5, 1.5, 0.01)
    gx, gy = np.meshgrid(x + g, y + g)
    ground = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, GROUND)])
    ground = ground[np.hypot(ground[:, 0] - x, ground[:, 1] - y) > r]
    return np.concatenate([stem, ground])


def sweep_of(points, distance, bearing, lidar, sections=None):
    """The sweep (sensor frame) and its rings and steps, and the sensor's position and unit vector from the axis."""
    position, yaw = tvb.sensor_pose(STEM[:2], GROUND, distance, bearing, lidar)
    if sections is not None:
        points = points[~tvb.behind_stem(points, position[:2], GROUND, sections)]
    sweep, ring, step = tvb.resample(tvb.to_sensor(points, position, yaw), lidar)
    return sweep, ring, step


def test_the_lidar_keeps_one_return_per_beam_on_the_facing_side_in_every_ring():
    lidar = tvb.Lidar()
    cloud = cylinder_cloud()
    for distance, bearing in ((3.0, 0.5), (6.0, 2.0)):
        sweep, ring, step = sweep_of(cloud, distance, bearing, lidar)
        cells = ring * lidar.azimuth_cells + step
        assert len(np.unique(cells)) == len(sweep) > 0
        on_stem = np.hypot(sweep[:, 0] - distance, sweep[:, 1]) < STEM[2] + 0.01
        # 1.8 m up, 3 m away: the rings meet the stem from 1.0 to 2.6 m; at 6 m the lowest meets the ground behind it
        assert sorted(set(ring[on_stem])) == list(range(16))
        # the visible arc ends where the lines of sight touch the stem: (p - c) . u >= r * r / distance
        u = np.array([-1.0, 0.0])  # from the axis to the sensor, in the sensor's frame
        facing = (sweep[on_stem, :2] - [distance, 0.0]) @ u
        assert facing.min() > STEM[2] ** 2 / distance - 0.005
        # every beam across the silhouette (2 asin(r / d)) returns from the stem
        width = 2 * np.degrees(np.arcsin(STEM[2] / distance)) / lidar.azimuth_step
        per_ring = np.bincount(ring[on_stem], minlength=16)
        assert np.all(per_ring >= int(width) - 1) and np.all(per_ring <= int(width) + 4), (width, per_ring)
        if distance == 6.0:
            assert np.count_nonzero(~on_stem & (sweep[:, 2] < -1.7)) > 100  # ground behind the stem
    # at 3 m the stem hides the ground: no beam of the lowest ring reaches it within 1.5 m of the axis
    sweep, ring, _ = sweep_of(cloud, 3.0, 0.0, lidar)
    assert np.all(sweep[:, 2] > -1.0)


def test_a_hole_in_the_scan_does_not_show_the_far_side_of_the_stem():
    lidar = tvb.Lidar()
    cloud = cylinder_cloud(hole=True)
    sections = tvb.stem_sections(cloud, GROUND, np.array(STEM[:2]), STEM[2], 3.0)
    assert np.allclose(sections[2], STEM[2], atol=0.002) and np.allclose(sections[1], STEM[:2], atol=0.002)
    sweep, ring, _ = sweep_of(cloud, 3.0, 0.0, lidar)
    far = sweep[:, 0] > 3.0 + 0.05
    assert np.count_nonzero(far) > 5  # through the hole, the stem's far side
    sweep, ring, _ = sweep_of(cloud, 3.0, 0.0, lidar, sections)
    assert not np.any(sweep[:, 0] > 3.0 + 0.01)
    assert np.any(np.abs(sweep[:, 2] + 1.8 - 1.3) < 0.2)  # the beams beside the hole still return


def test_range_noise_moves_returns_along_their_line_of_sight():
    lidar = tvb.Lidar()
    a = np.radians(11.4)  # the axis of azimuth step 57
    points = np.array([[3.0, 0.0, 3.0 * np.tan(np.radians(-1.0))],  # on the axes of beams of rings 7 and 9
                       [5.0 * np.cos(a), 5.0 * np.sin(a), 5.0 * np.tan(np.radians(3.0))]])
    clean, ring, step = tvb.resample(points, lidar)
    # a point is inside every beam within the beam's half width plus the angle of its voxel: 3 steps at 3 m, 1 at 5 m
    assert sorted(zip(ring.tolist(), step.tolist())) == [(7, 0), (7, 1), (7, 1799), (9, 57)]
    assert np.array_equal(np.unique(clean, axis=0), points)
    noisy, _, _ = tvb.resample(points, lidar, np.random.default_rng(1))
    again, _, _ = tvb.resample(points, lidar, np.random.default_rng(1))
    assert np.array_equal(noisy, again) and not np.allclose(noisy, clean)
    unit = clean / np.linalg.norm(clean, axis=1)[:, None]
    assert np.allclose(np.cross(noisy, unit), 0.0, atol=1e-12)


@pytest.fixture
def built():
    try:
        paths.program('cloud_trunks')
    except ValueError:
        pytest.skip('cloud_trunks is not built')


def run(argv, capsys):
    code = tvb.main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def test_the_benchmark_finds_the_cylinder(tmp_path, capsys, built):
    pcd = str(tmp_path / 'cylinder.pcd')
    extract_trunks.write_pcd(pcd, cylinder_cloud())
    out = tmp_path / 'out'
    code, text, err = run(['--cloud', pcd, '--stem', '0.41,-0.19,0.14', '--distances', '3,6', '--bearings', '3',
                           '--range-sigma', '0', '--out', str(out), '--keep-sweeps'], capsys)
    assert code == 0, err
    summary = json.loads((out / 'summary.json').read_text())
    ref = summary['references'][0]
    assert abs(ref['dbh'] - 2 * STEM[2]) < 0.002 and abs(ref['ground'] - GROUND) < 0.002
    assert np.hypot(ref['x'] - STEM[0], ref['y'] - STEM[1]) < 0.002
    for key in ('sweep_detector', 'stem_finder'):
        rows = summary[key]
        assert [r['distance'] for r in rows] == [3.0, 6.0]
        for r in rows:
            assert r['sweeps'] == 3 and r['found'] == 1.0 and r['spurious_per_sweep'] == 0.0, (key, r)
            assert abs(r['dbh_error_median']) < 0.01 and abs(r['dbh_error_worst']) < 0.015, (key, r)
    assert '| cylinder | 3 m |' in text and '100 %' in text
    lines = (out / 'sweeps.csv').read_text().splitlines()
    assert len(lines) == 1 + 2 * 2 * 3 and lines[0].startswith('tree,distance,bearing_deg,returns,rings,')
    sweep = tvb.read_pcd(str(out / 'sweeps' / 'cylinder_3m_001.pcd'))
    stem = sweep[np.hypot(sweep[:, 0] - 3.0, sweep[:, 1]) < 0.2]
    assert len(stem) > 400 and -0.85 < stem[:, 2].min() < stem[:, 2].max() < 0.85


def test_with_range_noise_the_per_sweep_detector_still_finds_the_cylinder(tmp_path, capsys, built):
    pcd = str(tmp_path / 'cylinder.pcd')
    extract_trunks.write_pcd(pcd, cylinder_cloud())
    code, text, err = run(['--cloud', pcd, '--stem', '0.4,-0.2,0.15', '--distances', '3', '--bearings', '2',
                           '--out', str(tmp_path)], capsys)
    assert code == 0, err
    row = json.loads((tmp_path / 'summary.json').read_text())['sweep_detector'][0]
    assert row['found'] == 1.0 and abs(row['dbh_error_median']) < 0.02


def test_cloud_trunks_runs_the_per_sweep_detector_on_a_sweep(tmp_path, built):
    """cloud_trunks --detector sweep: the trunk in the sensor's frame, the counts, and its errors."""
    sweep, _, _ = sweep_of(cylinder_cloud(), 4.0, 0.0, tvb.Lidar())
    pcd = str(tmp_path / 'sweep.pcd')
    extract_trunks.write_pcd(pcd, sweep)
    program = paths.program('cloud_trunks')

    def cloud_trunks(*args):
        return subprocess.run([program, pcd, str(tmp_path)] + list(args), stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, universal_newlines=True)

    r = cloud_trunks('--detector', 'sweep', '--config', paths.package_file('config', 'trunk_extraction.yaml'),
                     '--sensor-height', '1.8')
    assert r.returncode == 0 and r.stderr == '', r.stderr
    trunks = tvb.read_rows(str(tmp_path / 'trunks.csv'))
    assert len(trunks) == 1 and trunks[0]['method'] == 'circle'
    assert abs(trunks[0]['x'] - 4.0) < 0.01 and abs(trunks[0]['y']) < 0.01 and abs(trunks[0]['radius'] - 0.15) < 0.005
    counts = tvb.read_summary(str(tmp_path / 'summary.txt'))
    assert counts['points_read'] == len(sweep) and counts['trunks'] == 1 and counts['band_points'] > 100
    for wrong in (['--detector', 'sweep', '--sensor', '0,0,0'], ['--config', 'x.yaml'], ['--sensor-height', '1'],
                  ['--detector', 'circles'], ['--detector', 'sweep', '--sensor-height', '-1']):
        r = cloud_trunks(*wrong)
        assert r.returncode == 2 and r.stderr.startswith('usage:'), wrong
    (tmp_path / 'bad.yaml').write_text('min_radius: 2.0\n')
    r = cloud_trunks('--detector', 'sweep', '--config', str(tmp_path / 'bad.yaml'))
    assert r.returncode == 1
    assert r.stderr.startswith('error: %s: invalid parameter: min_radius' % (tmp_path / 'bad.yaml')), r.stderr


def test_command_line_errors(tmp_path, capsys, monkeypatch):
    monkeypatch.delenv(paths.DATA_ENV, raising=False)
    with pytest.raises(SystemExit) as e:
        tvb.main(['--cloud', 'x.pcd'])
    assert e.value.code == 2 and '--cloud and --stem' in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        tvb.main(['--keep-sweeps'])
    assert e.value.code == 2 and '--keep-sweeps needs --out' in capsys.readouterr().err
    try:
        paths.program('cloud_trunks')
    except ValueError:
        return
    code, out, err = run([], capsys)
    assert code == 1 and err.startswith('tree_view_benchmark: no data: give --data DIR or set %s' % paths.DATA_ENV)
    code, out, err = run(['--data', str(tmp_path), '--trees', 'oak'], capsys)
    assert code == 1 and 'unknown tree oak' in err
    code, out, err = run(['--data', str(tmp_path)], capsys)
    assert code == 1 and 'pine.pcd: no such file' in err


@pytest.mark.skipif(not os.environ.get(paths.DATA_ENV), reason='%s is not set' % paths.DATA_ENV)
def test_the_treels_trees_through_the_lidar(tmp_path, capsys, built):
    code, text, err = run(['--distances', '3,9', '--bearings', '4', '--out', str(tmp_path)], capsys)
    assert code == 0, err
    with capsys.disabled():
        print('\n' + text)
    summary = json.loads((tmp_path / 'summary.json').read_text())
    refs = {r['tree']: r for r in summary['references']}
    assert abs(refs['pine']['dbh'] - 0.252) < 0.0005 and abs(refs['spruce']['dbh'] - 0.231) < 0.0005
    rows = {(r['tree'], r['distance']): r for r in summary['sweep_detector']}
    assert sorted(rows) == [('pine', 3.0), ('pine', 9.0), ('spruce', 3.0), ('spruce', 9.0)]
    for distance in (3.0, 9.0):
        pine = rows[('pine', distance)]
        assert pine['found'] == 1.0 and abs(pine['dbh_error_worst']) < 0.05, pine
        assert pine['rings'] >= 14
