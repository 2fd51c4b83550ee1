"""rbpf_slam.extract_trunks (scripts/extract_trunks) and rbpf_slam.make_forest_cloud on small made-up files: every
format, every fault (one line naming the file, exit code 1, nothing written) and the outputs."""
import os
import struct
import sys

import numpy as np
import pytest

from rbpf_slam import extract_trunks, make_forest_cloud, paths, tree_view_benchmark

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HEADER = ('# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n'
          'COUNT 1 1 1\nWIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA %s\n')
STEM = (1.0, -0.5, 0.12)  # x, y, radius [m]


@pytest.fixture(autouse=True)
def _built():
    try:
        paths.program('cloud_trunks')
    except ValueError:
        pytest.skip('cloud_trunks is not built')


def tree(seed=1):
    """One stem of 24 cm DBH (3 mm bark noise) at STEM on flat ground at z = 0.2, seen from all sides."""
    rng = np.random.default_rng(seed)
    h = rng.uniform(0.0, 4.0, 20000)
    a = rng.uniform(0.0, 2 * np.pi, 20000)
    r = STEM[2] + rng.normal(0.0, 0.003, 20000)
    stem = np.column_stack([STEM[0] + r * np.cos(a), STEM[1] + r * np.sin(a), 0.2 + h])
    g = rng.uniform(-2.0, 2.0, (8000, 2))
    ground = np.column_stack([g, 0.2 + rng.normal(0.0, 0.01, 8000)])
    return np.concatenate([stem, ground]).astype(np.float32)


def write_ascii(path, xyz):
    with open(path, 'w') as f:
        f.write(HEADER % (len(xyz), len(xyz), 'ascii'))
        for p in xyz:
            f.write('%r %r %r\n' % tuple(float(v) for v in p))


def write_binary_compressed(path, xyz):
    """binary_compressed with an LZF stream of literal runs only (valid LZF, no back references)."""
    raw = np.ascontiguousarray(np.asarray(xyz, dtype='<f4').T).tobytes()  # x..., y..., z...
    lzf = b''.join(bytes([len(raw[i:i + 32]) - 1]) + raw[i:i + 32] for i in range(0, len(raw), 32))
    with open(path, 'wb') as f:
        f.write((HEADER % (len(xyz), len(xyz), 'binary_compressed')).encode('ascii'))
        f.write(struct.pack('<II', len(lzf), len(raw)) + lzf)


def write_las(path, xyz, offset=(0.0, 0.0, 0.0), scale=0.001, point_format=0):
    """A LAS 1.2 file (point format 0, 20-byte records) of the points."""
    xyz = np.asarray(xyz, dtype=float)
    header = bytearray(227)
    header[0:4] = b'LASF'
    header[24], header[25] = 1, 2
    struct.pack_into('<HIIBHI', header, 94, 227, 227, 0, point_format, 20, len(xyz))
    struct.pack_into('<3d3d', header, 131, scale, scale, scale, *offset)
    if len(xyz):
        struct.pack_into('<6d', header, 179, *(v for i in range(3) for v in (xyz[:, i].max(), xyz[:, i].min())))
    records = np.zeros(len(xyz), dtype=np.dtype([('xyz', '<i4', 3), ('rest', 'V8')]))
    records['xyz'] = np.round((xyz - np.asarray(offset)) / scale).astype('<i4')
    with open(path, 'wb') as f:
        f.write(bytes(header))
        f.write(records.tobytes())


def run(argv, capsys):
    code = extract_trunks.main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def read_csv(path):
    with open(path) as f:
        lines = f.read().splitlines()
    return lines[0], [dict(zip(lines[0].split(','), map(float, line.split(',')))) for line in lines[1:]]


def expect_one_trunk(prefix, x=STEM[0], y=STEM[1], z=0.0):
    header, rows = read_csv(prefix + '_trunks.csv')
    assert header == 'x,y,dbh,dbh_sigma,points,z_min,z_max'
    assert len(rows) == 1, rows
    t = rows[0]
    assert abs(t['x'] - x) < 0.01 and abs(t['y'] - y) < 0.01, t
    assert abs(t['dbh'] - 2 * STEM[2]) < 0.01, t
    assert 0.0 <= t['dbh_sigma'] < 0.01 and t['points'] > 100, t
    assert 0.5 < t['z_min'] - z < t['z_max'] - z < 3.5, t
    assert os.path.getsize(prefix + '_trunks.png') > 10000


def expect_nothing_written(folder):
    assert not [n for n in os.listdir(str(folder)) if 'trunks' in n], os.listdir(str(folder))


@pytest.mark.parametrize('encoding', ['ascii', 'binary', 'binary_compressed'])
def test_a_pcd_tree_gives_one_trunk_of_its_diameter(tmp_path, capsys, encoding):
    cloud = str(tmp_path / 'tree.pcd')
    {'ascii': write_ascii, 'binary': extract_trunks.write_pcd,
     'binary_compressed': write_binary_compressed}[encoding](cloud, tree())
    code, out, err = run([cloud], capsys)
    assert code == 0, err
    expect_one_trunk(str(tmp_path / 'tree'))  # the default prefix: beside the cloud
    assert '1 trunk' in out and 'DBH 24.' in out and err == ''


def test_a_las_file_keeps_its_large_coordinates(tmp_path, capsys):
    offset = (512000.0, 5402000.0, 300.0)
    cloud = str(tmp_path / 'plot.las')
    write_las(cloud, tree().astype(float) + np.asarray(offset), offset=offset)
    code, out, err = run([cloud, '--out', str(tmp_path / 'res')], capsys)
    assert code == 0, err
    expect_one_trunk(str(tmp_path / 'res'), STEM[0] + offset[0], STEM[1] + offset[1], offset[2])


def test_a_single_viewpoint_scan_with_its_sensor(tmp_path, capsys):
    pts = tree()
    front = (pts[:, 0] - STEM[0] < 0.0) | (pts[:, 2] < 0.3)  # the half facing a sensor at -x, and the ground
    cloud = str(tmp_path / 'scan.pcd')
    extract_trunks.write_pcd(cloud, pts[front])
    code, out, err = run([cloud, '--sensor=-4,-0.5,1.8', '--ground-height', '0.2'], capsys)
    assert code == 0, err
    expect_one_trunk(str(tmp_path / 'scan'))


def test_nan_points_are_dropped_with_a_warning(tmp_path, capsys):
    pts = tree()
    pts[::100, 2] = np.nan
    cloud = str(tmp_path / 'holes.pcd')
    extract_trunks.write_pcd(cloud, pts)
    code, out, err = run([cloud], capsys)
    assert code == 0, err
    assert err == 'extract_trunks: %s: %d of %d points have coordinates that are not finite, dropped\n' % (
        cloud, len(pts[::100]), len(pts))
    expect_one_trunk(str(tmp_path / 'holes'))


def fault_files(folder):
    """name -> (file, what the error says)"""
    pts = tree()
    files = {}
    p = str(folder / 'truncated.pcd')
    extract_trunks.write_pcd(p, pts)
    with open(p, 'r+b') as f:
        f.truncate(os.path.getsize(p) - 5000)
    files['truncated pcd'] = (p, 'truncated or malformed')
    p = str(folder / 'garbage.pcd')
    with open(p, 'wb') as f:
        f.write(b'\x00\x01 this is no point cloud\n' * 10)
    files['malformed pcd'] = (p, 'not a PCD file')
    p = str(folder / 'points.xyz')
    with open(p, 'w') as f:
        f.write('1 2 3\n4 5 6\n')
    files['unknown format'] = (p, 'not a PCD, LAS or LAZ file')
    p = str(folder / 'ascii_short.pcd')
    write_ascii(p, pts[:50])
    with open(p) as f:
        text = f.read().replace('POINTS 50', 'POINTS 60').replace('WIDTH 50', 'WIDTH 60')
    with open(p, 'w') as f:
        f.write(text)
    files['short ascii pcd'] = (p, 'truncated or malformed')
    p = str(folder / 'truncated.las')
    write_las(p, pts)
    with open(p, 'r+b') as f:
        f.truncate(os.path.getsize(p) - 100)
    files['truncated las'] = (p, 'truncated: the header announces %d points' % len(pts))
    p = str(folder / 'nan.pcd')
    extract_trunks.write_pcd(p, np.full((20, 3), np.nan))
    files['only nan'] = (p, 'no point has finite coordinates')
    p = str(folder / 'empty.pcd')
    extract_trunks.write_pcd(p, np.zeros((0, 3)))
    files['empty pcd'] = (p, 'the cloud holds no points')
    p = str(folder / 'empty.las')
    write_las(p, np.zeros((0, 3)))
    files['empty las'] = (p, 'the cloud holds no points')
    return files


def test_every_fault_is_one_line_naming_the_file_and_nothing_is_written(tmp_path, capsys):
    inputs = tmp_path / 'in'
    inputs.mkdir()
    out = tmp_path / 'out'
    out.mkdir()
    for name, (path, reason) in sorted(fault_files(inputs).items()):
        code, stdout, err = run([path, '--out', str(out / 'r')], capsys)
        assert code == 1, name
        lines = [line for line in err.splitlines() if 'dropped' not in line]
        assert len(lines) == 1 and lines[0].startswith('extract_trunks: %s: ' % path), (name, err)
        assert reason in lines[0], (name, err)
        expect_nothing_written(out)


def test_a_failure_leaves_earlier_outputs_as_they_were(tmp_path, capsys):
    (tmp_path / 'r_trunks.csv').write_text('earlier\n')
    bad = tmp_path / 'bad.pcd'
    bad.write_text('VERSION 0.7\nFIELDS x y z\n')
    code, _, err = run([str(bad), '--out', str(tmp_path / 'r')], capsys)
    assert code == 1 and 'not a PCD file' in err
    assert (tmp_path / 'r_trunks.csv').read_text() == 'earlier\n'
    assert not (tmp_path / 'r_trunks.png').exists()
    assert sorted(os.listdir(str(tmp_path))) == ['bad.pcd', 'r_trunks.csv']


def test_a_laz_file_when_laspy_has_a_laz_backend(tmp_path, capsys):
    laspy = pytest.importorskip('laspy')
    if not laspy.LazBackend.detect_available():
        pytest.skip('laspy has no LAZ backend')
    las = laspy.create(point_format=0, file_version='1.2')
    las.header.scales = [0.001] * 3
    las.header.offsets = [0.0] * 3
    pts = tree().astype(float)
    las.x, las.y, las.z = pts[:, 0], pts[:, 1], pts[:, 2]
    cloud = str(tmp_path / 'tree.laz')
    las.write(cloud)
    code, _, err = run([cloud], capsys)
    assert code == 0, err
    expect_one_trunk(str(tmp_path / 'tree'))


def test_laz_without_laspy_names_the_module_to_install(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, 'laspy', None)  # import laspy then fails, as where it is not installed
    cloud = tmp_path / 'plot.laz'
    cloud.write_bytes(b'LASF' + bytes(400))
    code, _, err = run([str(cloud)], capsys)
    assert code == 1
    assert err == "extract_trunks: %s: reading LAZ needs the Python module laspy with a LAZ backend: pip install " \
                  "'laspy[lazrs]'\n" % cloud
    expect_nothing_written(tmp_path)


def test_command_line_errors(tmp_path, capsys):
    with pytest.raises(SystemExit) as e:
        extract_trunks.main(['--help'])
    assert e.value.code == 0
    out = capsys.readouterr().out
    assert 'Finds the tree trunks in a point-cloud file' in out and '--sensor' in out and '--ground-height' in out
    with pytest.raises(SystemExit) as e:
        extract_trunks.main([str(tmp_path / 'x.pcd'), '--sensor', '1,2'])
    assert e.value.code == 2
    assert "argument --sensor: expected X,Y,Z in metres, got '1,2'" in capsys.readouterr().err
    code, _, err = run([str(tmp_path / 'missing.pcd')], capsys)
    assert code == 1 and err == 'extract_trunks: %s: no such file\n' % (tmp_path / 'missing.pcd')
    cloud = str(tmp_path / 'tree.pcd')
    extract_trunks.write_pcd(cloud, tree())
    code, _, err = run([cloud, '--out', str(tmp_path / 'no' / 'such' / 'dir')], capsys)
    assert code == 1 and 'the output folder does not exist' in err and len(err.splitlines()) == 1


@pytest.mark.parametrize('name,origin', [('stand.pcd', '0,0'), ('stand.las', '512000,5402000')])
def test_a_synthetic_stand_gives_its_trees(tmp_path, capsys, name, origin):
    """make_forest_cloud's stand (branch whorls, crowns, shrubs): its stems are found with their DBH."""
    cloud = str(tmp_path / name)
    assert make_forest_cloud.main([cloud, '--points', '600000', '--trees', '12', '--size', '12', '--seed', '3',
                                   '--origin', origin]) == 0
    code, out, err = run([cloud], capsys)
    assert code == 0, err
    _, truth = read_csv(str(tmp_path / 'stand_truth.csv'))
    _, found = read_csv(str(tmp_path / 'stand_trunks.csv'))
    assert all(abs(f['x'] - float(origin.split(',')[0]) - 6.0) < 6.0 for f in found), found
    errors = []
    for t in truth:
        near = [f for f in found if np.hypot(f['x'] - t['x'], f['y'] - t['y']) < 0.5 * t['dbh']]
        if near:
            errors.append(near[0]['dbh'] - t['dbh'])
    assert len(errors) >= 11 and len(found) <= len(truth), (len(errors), len(found))
    assert np.median(np.abs(errors)) < 0.01, errors


# --- The two TreeLS trees of the data folder ($RBPF_SLAM_DATA/treels), when it is given --------------------------
# (their reference fit is tree_view_benchmark.reference_fit, which tree_view_benchmark measures against too)

@pytest.mark.skipif(not os.environ.get(paths.DATA_ENV), reason='%s is not set' % paths.DATA_ENV)
@pytest.mark.parametrize('name', sorted(tree_view_benchmark.TREES))
def test_the_treels_trees_match_their_reference_fit(tmp_path, capsys, name):
    cloud = os.path.join(paths.data_dir(None, 'treels'), name + '.pcd')
    ground, centre, dbh, inliers, coverage = tree_view_benchmark.reference_fit(tree_view_benchmark.read_pcd(cloud),
                                                                               *tree_view_benchmark.TREES[name])
    code, out, err = run([cloud, '--out', str(tmp_path / name)], capsys)
    assert code == 0, err
    _, rows = read_csv(str(tmp_path / name) + '_trunks.csv')
    with capsys.disabled():
        print('\n%s: reference ground %.3f m, centre %.3f %.3f, DBH %.1f cm (%d points, %.0f %% of the ring); '
              'extract_trunks: %d trunk(s)%s' % (name, ground, centre[0], centre[1], 100 * dbh, inliers,
                                                  100 * coverage, len(rows), ''.join(
                                                      ', %.3f %.3f DBH %.1f ± %.1f cm' % (
                                                          t['x'], t['y'], 100 * t['dbh'], 100 * t['dbh_sigma'])
                                                      for t in rows)))
    assert len(rows) == 1
    assert abs(rows[0]['dbh'] - dbh) < 0.01
    assert np.hypot(rows[0]['x'] - centre[0], rows[0]['y'] - centre[1]) < 0.02
