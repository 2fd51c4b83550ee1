"""rbpf_slam.make_corridor_world (scripts/make_corridor_world): the corridor loop's map, YAML and waypoints."""
import os

from rbpf_slam import make_corridor_world as mcw


def test_the_world_files(tmp_path, capsys):
    out = str(tmp_path / 'corr')
    assert mcw.main([out, '--length', '60', '--width', '10']) == 0
    assert capsys.readouterr().out == ('wrote %s/corridor.{pgm,yaml} (674 x 174 cells) and corridor_loop.txt (148 m)\n'
                                       % out)
    with open(os.path.join(out, 'corridor_loop.txt')) as f:
        assert f.read() == '60 0\n60 10\n0 10\n0 0\n8 0\n'
    with open(os.path.join(out, 'corridor.yaml')) as f:
        yaml = f.read().splitlines()
    assert 'image: corridor.pgm' in yaml and 'resolution: 0.1' in yaml and 'origin: [-3.7, -3.7, 0.0]' in yaml
    with open(os.path.join(out, 'corridor.pgm'), 'rb') as f:
        pgm = f.read()
    header = b'P5\n# CREATOR: make_corridor_world.py 0.100 m/pix\n674 174\n255\n'
    assert pgm.startswith(header) and len(pgm) == len(header) + 674 * 174


def test_free_corridors_inside_walls_inside_unknown():
    canvas = mcw.build(60.0, 10.0)

    def at(x, y):  # the cell holding world point (x, y)
        col, row = int((x - canvas.x0) / mcw.RESOLUTION), int((y - canvas.y0) / mcw.RESOLUTION)
        return canvas.data[row * canvas.width + col]
    assert at(0.05, 0.05) == mcw.FREE  # the start
    assert at(30.05, 10.05) == mcw.FREE  # the north corridor
    assert at(30.05, 5.05) == mcw.UNKNOWN  # between the corridors
    assert at(-3.5, -3.5) == mcw.UNKNOWN  # the margin
    walls = [at(x + 0.05, -1.6) for x in range(0, 60)]  # the south corridor's south wall, doors set back into it
    assert walls.count(mcw.OCCUPIED) > 40 and mcw.FREE in walls
