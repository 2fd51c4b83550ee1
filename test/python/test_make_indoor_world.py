"""rbpf_slam.make_indoor_world (scripts/make_indoor_world): the shipped indoor world is what the generator makes."""
import os

from rbpf_slam import make_indoor_world as miw

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_the_shipped_world_is_made_again_byte_for_byte(tmp_path, capsys):
    out = str(tmp_path / 'out')
    assert miw.main([out]) == 0
    for name in ('indoor.pgm', 'indoor.yaml'):
        with open(os.path.join(ROOT, 'config', 'worlds', name), 'rb') as shipped, \
                open(os.path.join(out, name), 'rb') as made:
            assert made.read() == shipped.read(), name
    assert capsys.readouterr().out == ('wrote %s/indoor.{pgm,yaml}: 520 x 360 cells, loop 50.0 m, clearance >= '
                                       '0.95 m\n' % out)


def test_the_start_pose_is_the_world_origin():
    assert miw.to_world(*miw.START_BUILDING) == (0.0, 0.0)
    canvas = miw.build()
    assert (canvas.width, canvas.height) == (520, 360)
    min_clearance, length = miw.check(canvas)
    assert min_clearance >= miw.MIN_CLEARANCE and round(length, 1) == 50.0


def test_a_missing_folder_argument_is_a_usage_error(capsys):
    assert miw.main([]) == 2
    assert 'OUT_DIR' in capsys.readouterr().err
