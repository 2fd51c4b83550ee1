"""rbpf_slam.make_dense_forest (scripts/make_dense_forest): the shipped dense stand is what the generator makes."""
import os

from rbpf_slam import make_dense_forest as mdf

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_the_shipped_dense_forest_is_made_again_byte_for_byte(tmp_path, monkeypatch):
    rel = os.path.join('config', 'worlds', 'dense_forest.trees.txt')
    os.makedirs(str(tmp_path / 'config' / 'worlds'))
    monkeypatch.chdir(str(tmp_path))
    assert mdf.main(['150', '20240', rel]) == 0
    with open(os.path.join(ROOT, rel), 'rb') as shipped, open(str(tmp_path / rel), 'rb') as made:
        assert made.read() == shipped.read()


def test_the_stand_keeps_its_spacing_and_the_drive_clear():
    trees = mdf.generate(40, 7)
    assert len(trees) == 40 and trees == sorted(trees) and trees == mdf.generate(40, 7)
    for i, (x, y, r) in enumerate(trees):
        assert mdf.EDGE <= x <= mdf.STAND - mdf.EDGE and mdf.MIN_RADIUS <= r <= mdf.MAX_RADIUS
        assert abs(y - mdf.DRIVE_Y) - r >= mdf.DRIVE_CLEARANCE
        assert all((x - u) ** 2 + (y - v) ** 2 >= mdf.MIN_SPACING ** 2 for u, v, _ in trees[i + 1:])


def test_a_wrong_argument_count_is_a_usage_error(capsys):
    assert mdf.main(['10', '1']) == 2
    assert 'N SEED OUT.trees.txt' in capsys.readouterr().err
