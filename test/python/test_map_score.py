"""The package's two map scorers give the same numbers: rbpf_slam.evaluate.score_map (bags) and eval::scoreMap
(the C++ benchmarks) are both checked against the cases of test/data/map_score_cases.txt, whose expected lines
test/eval/test_map_score.cpp asserts for the C++ scorer."""
import os

import numpy as np
import pytest

from rbpf_slam.evaluate import score_map

CASES = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', 'data', 'map_score_cases.txt')


def read_cases(path):
    cases, trees, feats = [], [], []
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w or w[0].startswith('#'):
                continue
            if w[0] == 'case':
                trees, feats = [], []
            elif w[0] == 'tree':
                trees.append([float(v) for v in w[1:4]])
            elif w[0] == 'feature':
                feats.append([float(v) for v in w[1:4]])
            elif w[0] == 'expect':
                cases.append((np.array(trees).reshape(-1, 3), np.array(feats).reshape(-1, 3),
                              [int(v) for v in w[1:4]] + [float(v) for v in w[4:7]]))
    return cases


def test_the_cases_file_holds_cases_with_duplicates_and_spurious_features():
    cases = read_cases(CASES)
    assert len(cases) == 8
    assert sum(c[2][1] for c in cases) > 0 and sum(c[2][2] for c in cases) > 0


@pytest.mark.parametrize('index', range(8))
def test_the_python_scorer_gives_the_shared_numbers(index):
    trees, feats, (matched, dup, spur, recall, mean_error, radius_rms) = read_cases(CASES)[index]
    s = score_map(feats, trees, gate=0.5, duplicate_radius=1.0)
    assert (s['matched'], s['duplicates'], s['spurious']) == (matched, dup, spur)
    assert s['recall'] == pytest.approx(recall, abs=1e-8)
    assert s['mean_error'] == pytest.approx(mean_error, abs=1e-8)
    assert s['radius_rms'] == pytest.approx(radius_rms, abs=1e-8)
