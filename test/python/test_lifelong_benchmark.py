"""rbpf_slam.lifelong_benchmark (scripts/lifelong_benchmark): its pose algebra, seeds, the changed stand between
the visits and the georeferencing (the SLAM runs themselves need the built tools and are not run here)."""
import math
import os
import random
import re

import pytest

from rbpf_slam import lifelong_benchmark as lb


def test_compose_and_inverse():
    a, b = (1.0, 2.0, math.pi / 2), (3.0, 0.0, 0.1)
    c = lb.compose(a, b)
    assert c == pytest.approx((1.0, 5.0, math.pi / 2 + 0.1))
    assert lb.compose(lb.inverse(a), c) == pytest.approx(b)
    assert lb.compose(a, lb.inverse(a)) == pytest.approx((0.0, 0.0, 0.0))
    assert lb.world_to_map((0.0, 15.0, 0.0), (4.0, 16.0)) == pytest.approx((4.0, 1.0))


def test_seeds_and_the_nearest_sample():
    assert lb.parse_seeds('1-3,7') == [1, 2, 3, 7]
    samples = [(0.0, 'a'), (1.0, 'b'), (2.0, 'c')]
    assert lb.nearest(samples, 0.4) == (0.0, 'a') and lb.nearest(samples, 1.6) == (2.0, 'c')
    assert lb.nearest(samples, 9.0) == (2.0, 'c') and lb.nearest(samples, -1.0) == (0.0, 'a')


def test_east_north_of_a_fix():
    east, north = lb.geo_to_en(47.0, 8.0, 500.0, 47.001, 8.001)
    assert east == pytest.approx(76.062, abs=1e-3) and north == pytest.approx(111.180, abs=1e-3)
    assert lb.geo_to_en(47.0, 8.0, 500.0, 47.0, 8.0) == (0.0, 0.0)


def test_the_changed_stand(tmp_path):
    trees = [(x, y, 0.2) for x in range(0, 40, 4) for y in range(0, 40, 4)]  # 100 trees
    (tmp_path / 'w.trees.txt').write_text('# x y radius\n' + ''.join('%d %d %.1f\n' % t for t in trees))
    (tmp_path / 'w.yaml').write_text('ground: flat\ntrees: w.trees.txt\nclutter: none\n')
    out = tmp_path / 'out'
    out.mkdir()
    world2, box, felled, planted = lb.changed_world(str(tmp_path / 'w.yaml'), str(out), random.Random(3), 0.1, 0.05,
                                                    0.01)
    assert world2 == str(out / 'visit2.yaml') and box == (0, 0, 36, 36)
    assert (out / 'visit2.yaml').read_text() == 'ground: flat\ntrees: visit2.trees.txt\nclutter: none\n'
    assert len(felled) == 10 and all(tuple(f) + (0.2,) in trees for f in felled)
    kept = lb.read_trees(str(out / 'visit2.trees.txt'))
    assert len(kept) == 90 + len(planted) and 0 < len(planted) <= 5
    assert lb.world_trees_file(str(tmp_path / 'w.yaml')) == os.path.join(str(tmp_path), 'w.trees.txt')
    grown = [t for t in kept[:90]]
    assert all(0.2 <= t[2] <= 0.21 for t in grown)
    for x, y, r in kept[90:]:  # planted at least 1.5 m from every other trunk's surface
        assert all(math.hypot(x - u, y - v) > 1.5 + s for u, v, s in kept[:90])


def test_a_world_without_trees_is_refused(tmp_path):
    (tmp_path / 'w.yaml').write_text('ground: flat\n')
    with pytest.raises(ValueError, match=r'w.yaml:1: neither a world file \(no "trees:" line\) nor a tree list'):
        lb.world_trees_file(str(tmp_path / 'w.yaml'))
    (tmp_path / 'empty.txt').write_text('# nothing\n')
    with pytest.raises(ValueError, match='empty.txt: neither .* nor a tree list \\(no tree in it\\)'):
        lb.world_trees_file(str(tmp_path / 'empty.txt'))


def test_a_plain_tree_list_is_a_world(tmp_path):
    # The simulator's flat world from a plain list: the changed stand is a plain list too.
    trees = [(x, y, 0.15) for x in range(0, 20, 4) for y in range(0, 20, 4)]  # 25 trees
    plain = tmp_path / 'trees.txt'
    plain.write_text('# x y radius\n' + ''.join('%d %d %.2f  # tree\n' % t for t in trees))
    assert lb.world_trees_file(str(plain)) == str(plain)
    out = tmp_path / 'out'
    out.mkdir()
    world2, box, felled, planted = lb.changed_world(str(plain), str(out), random.Random(1), 0.2, 0.0, 0.0)
    assert world2 == str(out / 'visit2.trees.txt') and box == (0, 0, 16, 16)
    assert len(felled) == 5 and planted == []
    assert len(lb.read_trees(world2)) == 20
    assert lb.world_trees_file(world2) == world2


def test_a_file_that_is_no_world_is_refused_before_any_run(tmp_path, capsys):
    bad = tmp_path / 'notes.txt'
    bad.write_text('1 2 0.2\nthe stand north of the road\n')
    assert lb.main(['--worlds', str(bad), '--seeds', '1']) == 1
    err = capsys.readouterr().err
    assert err == 'lifelong_benchmark: %s:2: neither a world file (no "trees:" line) nor a tree list (x y radius ' \
                  'per line)\n' % bad, err


def test_a_missing_world_is_named(capsys):
    assert lb.main(['--worlds', 'no_such_world']) == 1
    assert 'no_such_world.yaml: no such world file' in capsys.readouterr().err


def test_record_scenarios_exit_statuses_are_the_ones_it_returns():
    # the benchmark tells a refused or colliding start from a broken tool by record_scenario's exit status
    header = os.path.join(os.path.dirname(__file__), '..', '..', 'include', 'rbpf_slam', 'sim', 'scenario.h')
    with open(header) as f:
        text = f.read()
    got = {name: int(value) for name, value in re.findall(r'constexpr int k(\w+) = (\d+);', text)}
    assert got == {'Collided': lb.COLLIDED, 'Refused': lb.REFUSED, 'TimedOut': lb.TIMED_OUT}
