"""rbpf_slam.plot_grid_run (scripts/plot_grid_run): its readers of map_server files and TUM paths, and a plot."""
import os

import numpy as np

from rbpf_slam import plot_grid_run as pg


def test_a_map_yaml_and_its_pgm(tmp_path):
    (tmp_path / 'map.pgm').write_bytes(b'P5\n# CREATOR: test 0.050 m/pix\n3 2\n255\n' + bytes([0, 205, 254, 254, 0, 205]))
    (tmp_path / 'map.yaml').write_text('image: map.pgm\nresolution: 0.050000\norigin: [-1.5, 2.25, 0.0]\n'
                                       '# origin: [9, 9, 9]\nnegate: 0\n')
    res, origin, image = pg.read_map_yaml(str(tmp_path / 'map.yaml'))
    assert res == 0.05 and origin == [-1.5, 2.25] and image == os.path.join(str(tmp_path), 'map.pgm')
    img = pg.read_pgm(image)
    assert img.dtype == np.uint8 and img.tolist() == [[0, 205, 254], [254, 0, 205]]


def test_not_a_binary_pgm_is_refused(tmp_path, capsys):
    (tmp_path / 'map.pgm').write_bytes(b'P2\n1 1\n255\n0\n')
    try:
        pg.read_pgm(str(tmp_path / 'map.pgm'))
    except ValueError as e:
        assert 'not a binary PGM' in str(e)
    else:
        raise AssertionError('a P2 file was read')


def test_an_empty_tum_file_is_an_empty_path(tmp_path):
    (tmp_path / 'e.tum').write_text('')
    t, xy = pg.read_tum(str(tmp_path / 'e.tum'))
    assert t.shape == (0,) and xy.shape == (0, 2)


def test_paths_are_plotted(tmp_path, capsys):
    for name, dy in (('a.tum', 0.0), ('b.tum', 0.1)):
        (tmp_path / name).write_text(''.join('%d %d %.1f 0 0 0 0 1\n' % (k, k, dy * k) for k in range(5)))
    out = str(tmp_path / 'paths.png')
    assert pg.main(['--paths', str(tmp_path / 'a.tum'), str(tmp_path / 'b.tum'), '--labels', 'a', 'b',
                    '--out', out]) == 0
    assert capsys.readouterr().out == 'wrote %s\n' % out
    with open(out, 'rb') as f:
        assert f.read(8) == b'\x89PNG\r\n\x1a\n'
