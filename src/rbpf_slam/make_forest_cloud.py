"""Writes a synthetic point cloud of a forest stand, as a terrestrial scan sees it from all sides, with its trees.

  make_forest_cloud OUT.pcd|OUT.las [--points 10000000] [--trees 60] [--size 30] [--seed 1] [--origin X,Y]

The stand is a square of SIZE metres on gently undulating ground: TREES stems (DBH 8-60 cm, tapering, leaning up to
4 degrees, 3 mm bark noise) with branch whorls from 2 m up and a crown, and shrubs between them. Of the points 20 %
lie on the ground, 45 % on the stems, 20 % on branches and crowns and 15 % on shrubs. Writes OUT.pcd (binary, float32
x y z) and beside it OUT_truth.csv (x, y, dbh of each stem at 1.3 m above the ground; metres), each complete or not
at all; OUT.las is a LAS 1.2 file (point format 0, millimetres) instead. --origin moves the stand's corner, e.g. to
projected coordinates. For timing and checking `extract_trunks`.
"""
import argparse
import os
import struct

import numpy as np

from rbpf_slam import atomic
from rbpf_slam.extract_trunks import write_pcd

PROG = 'make_forest_cloud'
SHARES = {'ground': 0.20, 'stems': 0.45, 'crowns': 0.20, 'shrubs': 0.15}


def ground_height(x, y):
    """The stand's ground [m]: a gentle undulation."""
    return 0.3 * np.sin(0.15 * x) + 0.2 * np.cos(0.11 * y)


def place_trees(rng, n, size):
    """Stem positions at least 1.5 m apart (by rejection), DBH, lean and the other shape parameters."""
    xy = []
    while len(xy) < n:
        for _ in range(100 * n):
            q = rng.uniform(1.0, size - 1.0, 2)
            if all(np.hypot(*(q - p)) >= 1.5 for p in xy):
                xy.append(q)
                break
        else:
            raise ValueError('%d trees do not fit 1.5 m apart in %g m' % (n, size))
    xy = np.array(xy)
    return {'xy': xy, 'dbh': rng.uniform(0.08, 0.6, n), 'taper': rng.uniform(0.005, 0.015, n),
            'lean': np.radians(rng.uniform(0.0, 4.0, n)), 'lean_dir': rng.uniform(0, 2 * np.pi, n),
            'crown_base': rng.uniform(4.0, 8.0, n), 'height': rng.uniform(15.0, 25.0, n)}


def axis(trees, i, h):
    """The axis of tree i at heights h above the ground."""
    t = np.tan(trees['lean'][i]) * h
    return (trees['xy'][i, 0] + t * np.cos(trees['lean_dir'][i]), trees['xy'][i, 1] + t * np.sin(trees['lean_dir'][i]))


def stem_points(rng, trees, n):
    """Points on the stems up to the crown base, more on the thick ones."""
    weight = trees['dbh'] * trees['crown_base']
    counts = rng.multinomial(n, weight / weight.sum())
    out = []
    for i, k in enumerate(counts):
        h = rng.uniform(0.0, trees['crown_base'][i], k)
        r = np.maximum(0.02, 0.5 * trees['dbh'][i] + trees['taper'][i] * (1.3 - h)) + rng.normal(0.0, 0.003, k)
        a = rng.uniform(0.0, 2 * np.pi, k)
        cx, cy = axis(trees, i, h)
        x, y = cx + r * np.cos(a), cy + r * np.sin(a)
        out.append(np.column_stack([x, y, ground_height(*trees['xy'][i]) + h]))
    return np.concatenate(out) if out else np.zeros((0, 3))


def crown_points(rng, trees, n):
    """Branch whorls every 0.6 m from 2 m up (horizontal, rising a little) and a crown of foliage above."""
    counts = rng.multinomial(n, np.full(len(trees['dbh']), 1.0 / len(trees['dbh'])))
    out = []
    for i, k in enumerate(counts):
        base = ground_height(*trees['xy'][i])
        k_branch = k // 3
        h0 = 2.0 + 0.6 * rng.integers(0, int((trees['height'][i] - 2.0) / 0.6), k_branch)
        a = rng.integers(0, 5, k_branch) * (2 * np.pi / 5) + i
        t = rng.uniform(0.0, 1.5, k_branch)
        cx, cy = axis(trees, i, h0)
        out.append(np.column_stack([cx + t * np.cos(a) + rng.normal(0, 0.01, k_branch),
                                    cy + t * np.sin(a) + rng.normal(0, 0.01, k_branch), base + h0 + 0.3 * t]))
        k_leaf = k - k_branch
        h = rng.uniform(trees['crown_base'][i], trees['height'][i], k_leaf)
        reach = 2.5 * (trees['height'][i] - h) / (trees['height'][i] - trees['crown_base'][i]) * np.sqrt(
            rng.uniform(0, 1, k_leaf))
        a = rng.uniform(0, 2 * np.pi, k_leaf)
        cx, cy = axis(trees, i, h)
        out.append(np.column_stack([cx + reach * np.cos(a), cy + reach * np.sin(a), base + h]))
    return np.concatenate(out) if out else np.zeros((0, 3))


def shrub_points(rng, size, n):
    """Shrubs: solid ellipsoids of foliage up to 1.5 m, 40 per 900 m²."""
    count = max(1, int(40 * size * size / 900.0))
    centres = rng.uniform(0.0, size, (count, 2))
    which = rng.integers(0, count, n)
    radius = rng.uniform(0.3, 0.8, count)[which]
    top = rng.uniform(0.5, 1.5, count)[which]
    a, d = rng.uniform(0, 2 * np.pi, n), radius * np.sqrt(rng.uniform(0, 1, n))
    z = top * rng.uniform(0, 1, n)
    x, y = centres[which, 0] + d * np.cos(a), centres[which, 1] + d * np.sin(a)
    return np.column_stack([x, y, ground_height(x, y) + z])


def make_stand(n_points, n_trees, size, seed):
    """The points (float32, n × 3, shuffled) and the trees of a synthetic stand."""
    rng = np.random.default_rng(seed)
    trees = place_trees(rng, n_trees, size)
    n = {k: int(v * n_points) for k, v in SHARES.items()}
    n['ground'] += n_points - sum(n.values())
    x, y = rng.uniform(0, size, n['ground']), rng.uniform(0, size, n['ground'])
    parts = [np.column_stack([x, y, ground_height(x, y) + rng.normal(0, 0.01, n['ground'])]).astype(np.float32)]
    parts.append(stem_points(rng, trees, n['stems']).astype(np.float32))
    parts.append(crown_points(rng, trees, n['crowns']).astype(np.float32))
    parts.append(shrub_points(rng, size, n['shrubs']).astype(np.float32))
    points = np.concatenate(parts)
    rng.shuffle(points)
    return points, trees


def write_las(path, xyz, origin):
    """A LAS 1.2 file of the points moved by origin (x, y): point format 0, a scale of 1 mm, offset origin."""
    n = len(xyz)
    header = bytearray(227)
    header[0:4] = b'LASF'
    header[24], header[25] = 1, 2
    struct.pack_into('<HIIBHI', header, 94, 227, 227, 0, 0, 20, n)
    struct.pack_into('<3d3d', header, 131, 0.001, 0.001, 0.001, origin[0], origin[1], 0.0)
    lo, hi = xyz.min(axis=0).astype(float), xyz.max(axis=0).astype(float)
    struct.pack_into('<6d', header, 179, hi[0] + origin[0], lo[0] + origin[0], hi[1] + origin[1], lo[1] + origin[1],
                     hi[2], lo[2])
    records = np.zeros(n, dtype=np.dtype([('xyz', '<i4', 3), ('rest', 'V8')]))
    records['xyz'] = np.round(xyz.astype(float) / 0.001).astype('<i4')
    with open(path, 'wb') as f:
        f.write(bytes(header))
        f.write(records.tobytes())


def truth_csv(trees, origin=(0.0, 0.0)):
    lines = ['x,y,dbh']
    for i in range(len(trees['dbh'])):
        cx, cy = axis(trees, i, 1.3)
        lines.append('%.4f,%.4f,%.4f' % (cx + origin[0], cy + origin[1], trees['dbh'][i]))
    return '\n'.join(lines) + '\n'


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr when the output cannot be written; 2 for a wrong
    command line."""
    return atomic.run_tool(PROG, _main, argv, errors=(ValueError,))


def _main(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('out', metavar='OUT.pcd')
    p.add_argument('--points', type=int, default=10000000)
    p.add_argument('--trees', type=int, default=60)
    p.add_argument('--size', type=float, default=30.0, help='side of the square stand [m]')
    p.add_argument('--seed', type=int, default=1)
    p.add_argument('--origin', metavar='X,Y', default='0,0', help='the stand\'s corner [m] (default: 0,0)')
    args = p.parse_args(argv)
    try:
        origin = [float(v) for v in args.origin.split(',')]
    except ValueError:
        origin = []
    if len(origin) != 2 or not np.all(np.isfinite(origin)):
        p.error('--origin must be X,Y in metres')
    if origin != [0.0, 0.0] and not args.out.lower().endswith('.las'):
        p.error('--origin needs a LAS output (a PCD holds single precision)')
    if args.points < 1000 or args.trees < 1 or not args.size > 3.0:
        p.error('--points must be >= 1000, --trees >= 1 and --size > 3')
    points, trees = make_stand(args.points, args.trees, args.size, args.seed)
    truth = os.path.splitext(args.out)[0] + '_truth.csv'
    with atomic.atomic_output(args.out) as tmp_cloud, atomic.atomic_output(truth) as tmp_truth:
        if args.out.lower().endswith('.las'):
            write_las(tmp_cloud, points, origin)
        else:
            write_pcd(tmp_cloud, points)
        with open(tmp_truth, 'w') as f:
            f.write(truth_csv(trees, origin))
    print('%s: %d points, %d trees on %g × %g m; trees in %s' % (args.out, len(points), args.trees, args.size,
                                                                  args.size, truth))
    return 0
