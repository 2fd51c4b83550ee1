"""Writes a tree list for the forest simulator: a stand of touching pairs, of clumps, or of plantation rows.

Usage: rosrun rbpf_slam make_stand KIND SEED OUT.trees.txt
  KIND: touching_pairs  30 x 30 m: 12 pairs of trunks whose bark gap at breast height is 0.02-0.10 m, radii
                        0.10-0.30 m, each pair turned at random, and 8 single trunks
        clumped         40 x 40 m (-5 .. 35): 40 trunks in 7 clumps (centres >= 3.5 m from the drives), radii
                        0.07-0.35 m, bark gaps >= 0.5 m
        plantation_rows 40 x 40 m (-5 .. 35): rows 4 m apart along x, trunks 3 m apart in a row, jitter
                        0.15 m (standard deviation), radii 0.08-0.20 m

Every stand keeps each trunk surface at least 1.5 m from the drives of the simulated scenario (the robot starts
at (0, 15) heading +x): the line y = 15 (the straight drive, and the loop's straight legs) and the circle of
radius 8.5 m about (15, 15) (the loop). Python's random.Random(seed) gives the same sequence on every Python 3,
and values are rounded before they are checked, so the same KIND and SEED give the same file byte for byte.
"""
import math
import random
import sys

from rbpf_slam import atomic  # the package's one atomic writer

DRIVE_Y = 15.0  # [m] the straight drive runs along y = DRIVE_Y
LOOP_CENTER = (15.0, 15.0)  # [m] the loop drive's circle
LOOP_RADIUS = 8.5  # [m]
DRIVE_CLEARANCE = 1.5  # [m] from the drives to any trunk surface
TAPER = 0.01  # [m/m] the worlds' taper: the list's radius is at the ground
BREAST_HEIGHT = 1.3  # [m]
MAX_ATTEMPTS = 1000000


def clear_of_drives(x, y, r):
    if abs(y - DRIVE_Y) - r < DRIVE_CLEARANCE:
        return False
    d = math.hypot(x - LOOP_CENTER[0], y - LOOP_CENTER[1])
    return abs(d - LOOP_RADIUS) - r >= DRIVE_CLEARANCE


def gap(a, b):
    """Bark gap between two trunks (x, y, r) at the ground [m]."""
    return math.hypot(a[0] - b[0], a[1] - b[1]) - a[2] - b[2]


class Budget:
    def __init__(self, what):
        self.what = what
        self.attempts = 0

    def spend(self):
        self.attempts += 1
        if self.attempts > MAX_ATTEMPTS:
            raise RuntimeError('%s: no room after %d attempts' % (self.what, MAX_ATTEMPTS))


def touching_pairs(rng):
    stand, edge = 30.0, 0.5
    n_pairs, n_single = 12, 8
    min_gap_other = 1.0  # [m] bark gap to every trunk outside the pair
    trees, pairs = [], []
    budget = Budget('touching_pairs')
    while len(pairs) < n_pairs:
        budget.spend()
        x = round(rng.uniform(edge, stand - edge), 3)
        y = round(rng.uniform(edge, stand - edge), 3)
        r1 = round(rng.uniform(0.10, 0.30), 3)
        r2 = round(rng.uniform(0.10, 0.30), 3)
        g = rng.uniform(0.02, 0.10)  # at breast height, where the taper has narrowed both trunks
        a = rng.uniform(0.0, math.pi)
        d = r1 + r2 - 2.0 * TAPER * BREAST_HEIGHT + g
        x2 = round(x + d * math.cos(a), 3)
        y2 = round(y + d * math.sin(a), 3)
        t1, t2 = (x, y, r1), (x2, y2, r2)
        g_bh = gap(t1, t2) + 2.0 * TAPER * BREAST_HEIGHT
        if not (0.02 <= g_bh <= 0.10):
            continue
        if not all(edge <= v <= stand - edge for v in (x2, y2)):
            continue
        if not (clear_of_drives(*t1) and clear_of_drives(*t2)):
            continue
        if any(gap(t, o) < min_gap_other for t in (t1, t2) for o in trees):
            continue
        trees += [t1, t2]
        pairs.append((t1, t2, g_bh))
    singles = 0
    while singles < n_single:
        budget.spend()
        t = (round(rng.uniform(edge, stand - edge), 3), round(rng.uniform(edge, stand - edge), 3),
             round(rng.uniform(0.10, 0.30), 3))
        if not clear_of_drives(*t) or any(gap(t, o) < min_gap_other for o in trees):
            continue
        trees.append(t)
        singles += 1
    header = ('# x y radius (m). 30 x 30 m stand: %d pairs of touching trunks (bark gap at breast height '
              '0.02-0.10 m,\n# radii 0.10-0.30 m at the ground, the pair turned at random) and %d single trunks; '
              'every other\n# bark gap >= %.1f m. Pairs, each followed by its gap at breast height:\n'
              % (n_pairs, n_single, min_gap_other))
    header += ''.join('#   (%.3f, %.3f) (%.3f, %.3f)  %.3f m\n' % (a[0], a[1], b[0], b[1], g) for a, b, g in pairs)
    return sorted(trees), header


def clumped(rng):
    lo, hi = -5.0, 35.0
    n_clumps, n_trees = 7, 40
    clump_sigma = 1.5  # [m] spread of a clump's trunks about its centre
    min_gap = 0.5  # [m] bark gap between any two trunks
    budget = Budget('clumped')
    centers = []
    while len(centers) < n_clumps:
        budget.spend()
        c = (rng.uniform(lo + 3.0, hi - 3.0), rng.uniform(lo + 3.0, hi - 3.0))
        if not clear_of_drives(c[0], c[1], 2.0):  # whole clumps beside the drives, none cut by them
            continue
        if any(math.hypot(c[0] - o[0], c[1] - o[1]) < 8.0 for o in centers):
            continue
        centers.append(c)
    trees = []
    while len(trees) < n_trees:
        budget.spend()
        c = centers[len(trees) % n_clumps]
        t = (round(rng.gauss(c[0], clump_sigma), 3), round(rng.gauss(c[1], clump_sigma), 3),
             round(rng.uniform(0.07, 0.35), 3))
        if not (lo + 0.5 <= t[0] <= hi - 0.5 and lo + 0.5 <= t[1] <= hi - 0.5):
            continue
        if not clear_of_drives(*t) or any(gap(t, o) < min_gap for o in trees):
            continue
        trees.append(t)
    header = ('# x y radius (m). 40 x 40 m stand (-5 .. 35): %d trunks in %d clumps (a clump: trunks ~ N(centre, '
              '%.1f m)),\n# radii 0.07-0.35 m, bark gaps >= %.1f m. Clump centres: %s\n'
              % (n_trees, n_clumps, clump_sigma, min_gap, ' '.join('(%.1f, %.1f)' % c for c in centers)))
    return sorted(trees), header


def plantation_rows(rng):
    lo, hi = -5.0, 35.0
    row_spacing, tree_spacing, jitter = 4.0, 3.0, 0.15
    trees = []
    removed = 0
    y = DRIVE_Y - 2.0
    while y - row_spacing >= lo:
        y -= row_spacing
    while y <= hi - 0.5:
        x = lo + 1.0
        while x <= hi - 0.5:
            t = (round(x + rng.gauss(0.0, jitter), 3), round(y + rng.gauss(0.0, jitter), 3),
                 round(rng.uniform(0.08, 0.20), 3))
            if clear_of_drives(*t):
                trees.append(t)
            else:
                removed += 1
            x += tree_spacing
        y += row_spacing
    header = ('# x y radius (m). 40 x 40 m plantation (-5 .. 35): rows along x %.0f m apart (y = 13 - 4 k, 17 + 4 k), '
              'trunks\n# %.0f m apart in a row from x = -4, jitter %.2f m (standard deviation), radii 0.08-0.20 m; '
              'the %d trunks\n# nearer the loop drive are left out (a track through the stand).\n'
              % (row_spacing, tree_spacing, jitter, removed))
    return sorted(trees), header


KINDS = {'touching_pairs': touching_pairs, 'clumped': clumped, 'plantation_rows': plantation_rows}


def main(argv=None):
    """The command (@p argv: its arguments, default sys.argv[1:]): exit code 0; 2 for a usage error."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if len(argv) != 3 or argv[0] not in KINDS:
        sys.stderr.write('usage: python3 %s %s SEED OUT.trees.txt\n' % (sys.argv[0], '|'.join(sorted(KINDS))))
        return 2
    kind, seed, out = argv[0], int(argv[1]), argv[2]
    trees, header = KINDS[kind](random.Random(seed))
    for t in trees:
        assert clear_of_drives(*t), t
    text = header
    text += ('# No trunk surface within %.1f m of the line y = %g or of the circle of radius %g m about (%g, %g): '
             'the\n# straight and loop drives stay possible.\n'
             % (DRIVE_CLEARANCE, DRIVE_Y, LOOP_RADIUS, LOOP_CENTER[0], LOOP_CENTER[1]))
    text += '# Generated by: make_stand %s %d %s\n' % (kind, seed, out)
    text += '# (seed %d; do not edit by hand: change the script or the seed and regenerate).\n' % seed
    text += ''.join('%.3f %.3f %.3f\n' % t for t in trees)
    atomic.write_text(out, text)
    return 0
