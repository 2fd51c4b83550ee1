"""rbpf_slam.make_stand (scripts/make_stand): the shipped stands are what the generator makes from their seeds."""
import os

import pytest

from rbpf_slam import make_stand

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


@pytest.mark.parametrize('kind,seed', [('clumped', 11), ('plantation_rows', 5), ('touching_pairs', 7)])
def test_the_shipped_stand_is_made_again_byte_for_byte(tmp_path, monkeypatch, kind, seed):
    rel = os.path.join('config', 'worlds', kind + '.trees.txt')
    os.makedirs(str(tmp_path / 'config' / 'worlds'))
    monkeypatch.chdir(str(tmp_path))
    assert make_stand.main([kind, str(seed), rel]) == 0
    with open(os.path.join(ROOT, rel), 'rb') as shipped, open(str(tmp_path / rel), 'rb') as made:
        assert made.read() == shipped.read()


def test_every_trunk_keeps_clear_of_the_drives():
    import random
    for kind, make in sorted(make_stand.KINDS.items()):
        trees, header = make(random.Random(3))
        assert trees and header.startswith('#'), kind
        assert all(make_stand.clear_of_drives(*t) for t in trees), kind
    assert not make_stand.clear_of_drives(5.0, make_stand.DRIVE_Y + 0.5, 0.2)  # on the straight drive


def test_a_bad_kind_is_a_usage_error(tmp_path, capsys):
    assert make_stand.main(['oaks', '1', str(tmp_path / 'x.txt')]) == 2
    assert 'clumped|plantation_rows|touching_pairs SEED OUT.trees.txt' in capsys.readouterr().err
    assert not (tmp_path / 'x.txt').exists()
