"""How the two trunk extractors see a real tree through a robot's 16-ring lidar.

  tree_view_benchmark [--data DIR] [--trees pine,spruce] [--distances 3,6,9] [--bearings 24] [--seed 1]
      [--range-sigma 0.02] [--out DIR] [--keep-sweeps]
  tree_view_benchmark --cloud TREE.pcd --stem X,Y,R [...]

--data DIR is the directory holding the data sets (default: the environment variable RBPF_SLAM_DATA); the trees are
DIR/treels/pine.pcd and spruce.pcd, terrestrial scans of single trees seen from all sides. --cloud takes another
cloud of one tree (binary or ascii PCD, x y z; metres, z up) with a start for its reference fit (--stem: the stem's
axis and radius near breast height, read off a top view).

The reference: the ground at the stem and a circle fitted to the points 1.25-1.35 m above it (reference_fit), whose
centre is the true stem and whose diameter the reference DBH. A virtual lidar (16 rings over +-15 deg 2 deg apart,
0.2 deg azimuth steps, 1.8 m above the ground at the stem) stands at each distance from the stem at --bearings
bearings around it, facing it; each bearing is one sweep. Every (ring, azimuth step) keeps the nearest point inside
its beam (+-0.1 deg, widened by a point's voxel: see Lidar), the first return, moved along its line of sight by
Gaussian range noise (2 cm, seeded), in the sensor's frame (x towards the stem, z up). The stem is opaque: points
whose line of sight crosses its section (fitted every 10 cm, stem_sections) are hidden, since a scan's holes in the
stem's near side would otherwise show its far side. On each sweep the program cloud_trunks runs (a) the robot's
per-sweep detector with config/trunk_extraction.yaml and the sensor height and (b) the stem finder with the sensor's
position. A tree is found when a trunk lies within 0.5 m of the true stem; every other trunk is spurious.

Prints, per tree and distance, the share of sweeps that found the tree, the spurious trunks per sweep and the DBH
error (median and worst) against the reference, then the extractors' counts (where a sweep loses the tree). With
--out, writes OUT/sweeps.csv (one row per sweep and extractor) and OUT/summary.json; --keep-sweeps also the sweeps
as PCD files (OUT/sweeps/).
"""
import argparse
import collections
import csv
import os
import subprocess
import tempfile

import numpy as np

from rbpf_slam import atomic, extract_trunks, paths

PROG = 'tree_view_benchmark'

#: the data folder's trees and a start for their reference fits: axis x, y and radius [m], read off the top view of
#: the 1-2.5 m slab
TREES = collections.OrderedDict([('pine', (-0.06, 0.15, 0.13)), ('spruce', (0.16, 0.0, 0.13))])
#: a trunk this near the true stem [m] is the tree
MATCH_GATE = 0.5
DETECTOR_COUNTS = ('band_points', 'clusters', 'rejected_size', 'rejected_shape', 'rejected_radius',
                   'rejected_inliers', 'split_clusters', 'trunks')
FINDER_COUNTS = ('slice_points', 'clusters', 'circles', 'columns', 'stems')


class Lidar(object):
    """A spinning multi-ring lidar. Angles in degrees, lengths in metres.

    A beam reaches beam_half_width either side of its axis (about a VLP-16's divergence of 3 mrad). A cloud point
    stands for its voxel: it is inside a beam when the sphere of radius point_radius around it (half a 1 cm voxel's
    diagonal) touches the beam, so that a surface the voxel grid covers is closed to the beams; without it a near
    stem's 1 cm voxel columns let beams pass between them to its far side."""

    def __init__(self, rings=16, lowest=-15.0, ring_step=2.0, azimuth_step=0.2, beam_half_width=0.1, height=1.8,
                 range_sigma=0.02, point_radius=0.0087):
        self.rings = rings
        self.lowest = lowest
        self.ring_step = ring_step
        self.azimuth_step = azimuth_step
        self.beam_half_width = beam_half_width
        self.height = height
        self.range_sigma = range_sigma
        self.point_radius = point_radius

    @property
    def azimuth_cells(self):
        return int(round(360.0 / self.azimuth_step))


# --- The cloud and its reference ---------------------------------------------------------------------------------

def read_pcd(path):
    """The x y z of an ascii or binary PCD file as float64 (n x 3); ValueError for other files, naming the file."""
    try:
        return _read_pcd(path)
    except ValueError as e:
        raise ValueError('%s: %s' % (path, e))


def _read_pcd(path):
    header = extract_trunks.pcd_header(path)
    fields = header['FIELDS']
    sizes = [int(s) for s in header.get('SIZE', ['4'] * len(fields))]
    types = header.get('TYPE', ['F'] * len(fields))
    counts = [int(c) for c in header.get('COUNT', ['1'] * len(fields))]
    n = header['points']
    if header['DATA'][0] == 'ascii':
        columns = np.cumsum([0] + counts)
        with open(path, 'rb') as f:
            while not f.readline().startswith(b'DATA'):
                pass
            values = np.loadtxt(f, ndmin=2)
        xyz = np.column_stack([values[:, columns[fields.index(k)]] for k in 'xyz']).astype(float)
        return xyz[np.isfinite(xyz).all(axis=1)]
    if header['DATA'][0] != 'binary':
        raise ValueError('%s PCD is not read here: save the cloud as binary or ascii' % header['DATA'][0])
    kinds = {'F': 'f', 'I': 'i', 'U': 'u'}
    if any(t not in kinds for t in types):
        raise ValueError('unknown PCD TYPE %s' % ' '.join(types))
    dtype = np.dtype([(name, '<%s%d' % (kinds[t], s), (c,)) for name, s, t, c in zip(fields, sizes, types, counts)])
    with open(path, 'rb') as f:
        while not f.readline().startswith(b'DATA'):
            pass
        data = f.read(n * dtype.itemsize)
    if len(data) < n * dtype.itemsize:
        raise ValueError('truncated: the header announces %d points' % n)
    records = np.frombuffer(data, dtype=dtype, count=n)
    xyz = np.column_stack([records[k][:, 0] for k in 'xyz']).astype(float)
    return xyz[np.isfinite(xyz).all(axis=1)]


def geometric_circle(p, c, r):
    """Gauss-Newton on the points' distances to the circle, from (c, r)."""
    for _ in range(100):
        d = p - c
        dist = np.hypot(d[:, 0], d[:, 1])
        step = np.linalg.lstsq(np.c_[-d / dist[:, None], -np.ones(len(p))], r - dist, rcond=None)[0]
        c, r = c + step[:2], r + step[2]
        if np.abs(step).max() < 1e-10:
            break
    return c, r


def reference_fit(points, x, y, r):
    """The reference of a tree seen from all sides, from a start (x, y, r) near its stem: the ground at the stem (the
    median over 8 sectors of the third-lowest point 0.15-0.6 m from the axis) and a circle fitted to the points
    1.25-1.35 m above it, by geometric least squares trimmed to 4, 3, 2 and 1.5 cm. Returns the ground [m], the
    centre (2,), the DBH [m], the circle's points and the share of 36 sectors around it that they cover."""
    c = np.array([x, y], dtype=float)
    d = np.hypot(points[:, 0] - x, points[:, 1] - y)
    sector = np.floor((np.arctan2(points[:, 1] - y, points[:, 0] - x) + np.pi) / (np.pi / 4))
    ground = np.median([np.sort(points[(d > 0.15) & (d < 0.6) & (sector == k), 2])[2] for k in range(8)])
    s = points[(points[:, 2] > ground + 1.25) & (points[:, 2] < ground + 1.35)][:, :2]
    s = s[np.abs(np.hypot(s[:, 0] - x, s[:, 1] - y) - r) < 0.05]
    for band in (0.04, 0.03, 0.02, 0.015, 0.015, 0.015):
        inliers = s[np.abs(np.hypot(*(s - c).T) - r) < band]
        c, r = geometric_circle(inliers, c, r)
    a = np.arctan2(inliers[:, 1] - c[1], inliers[:, 0] - c[0])
    coverage = len(np.unique(np.floor((a + np.pi) / (2 * np.pi) * 36))) / 36.0
    return ground, c, 2 * r, len(inliers), coverage


def stem_sections(points, ground, centre, radius, top, step=0.1):
    """The stem's circle every ``step`` from the ground to ``top`` above it, followed up and down from the reference
    circle at 1.3 m: per slice a geometric fit to the points within 4 cm of the neighbour's circle, trimmed to 3, 2
    and 1.5 cm; a slice with fewer than 20 such points, or covering less than a quarter of its circle, takes the
    neighbour's. Returns the slices' heights above the ground (n,), centres (n x 2) and radii (n,)."""
    heights = np.arange(0.5 * step, top, step)
    centres = np.zeros((len(heights), 2))
    radii = np.zeros(len(heights))
    breast = int(np.argmin(np.abs(heights - 1.3)))
    z = points[:, 2] - ground
    for order in (range(breast, len(heights)), range(breast, -1, -1)):
        c, r = np.asarray(centre, dtype=float), float(radius)
        for i in order:
            s = points[np.abs(z - heights[i]) < 0.5 * step][:, :2]
            s = s[np.abs(np.hypot(s[:, 0] - c[0], s[:, 1] - c[1]) - r) < 0.04]
            if len(s) >= 20:
                fc, fr = c, r
                for band in (0.03, 0.02, 0.015):
                    inliers = s[np.abs(np.hypot(*(s - fc).T) - fr) < band]
                    if len(inliers) < 20:
                        break
                    fc, fr = geometric_circle(inliers, fc, fr)
                a = np.arctan2(s[:, 1] - fc[1], s[:, 0] - fc[0])
                if len(inliers) >= 20 and len(np.unique(np.floor((a + np.pi) / (np.pi / 12)))) >= 6 and \
                        abs(fr - r) < 0.03 and np.hypot(*(fc - c)) < 0.03:
                    c, r = fc, fr
            centres[i], radii[i] = c, r
    return heights, centres, radii


def behind_stem(points, sensor_xy, ground, sections, margin=0.02):
    """Which points the stem hides from a sensor at ``sensor_xy``: the horizontal line of sight to the point passes
    through the stem's section at the point's height, shrunk by ``margin`` (the bark's roughness). Where the scan
    has holes in the stem's side facing the sensor, its far side would show through them."""
    heights, centres, radii = sections
    z = points[:, 2] - ground
    inside = (z >= heights[0] - 0.05) & (z <= heights[-1] + 0.05)
    i = np.clip(np.round((z - heights[0]) / (heights[1] - heights[0])).astype(int), 0, len(heights) - 1)
    c = centres[i] - sensor_xy
    p = points[:, :2] - sensor_xy
    t = np.clip(np.sum(c * p, axis=1) / np.maximum(np.sum(p * p, axis=1), 1e-12), 0.0, 1.0)
    gap = np.hypot(*(c - t[:, None] * p).T)
    return inside & (gap < radii[i] - margin)


# --- The virtual lidar ---------------------------------------------------------------------------------------------

def sensor_pose(centre, ground, distance, bearing, lidar):
    """The sensor's position (3,) at ``distance`` from the stem's ``centre`` towards ``bearing`` [rad], lidar.height
    above the ``ground``, and its heading [rad] (facing the stem)."""
    position = np.array([centre[0] + distance * np.cos(bearing), centre[1] + distance * np.sin(bearing),
                         ground + lidar.height])
    return position, bearing + np.pi


def to_sensor(points, position, yaw):
    """Points (n x 3) in the sensor's frame: origin at ``position``, x along ``yaw``, z up."""
    d = points - position
    c, s = np.cos(yaw), np.sin(yaw)
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1], d[:, 2]])


def beam_cells(points, lidar):
    """Every (point, beam) pair with the point inside the beam: the point's index, the beam's ring and azimuth
    step, and the point's range. Points in the sensor's frame."""
    rng = np.linalg.norm(points, axis=1)
    idx = np.nonzero(rng > 0)[0]
    rng = rng[idx]
    p = points[idx]
    elevation = np.degrees(np.arctan2(p[:, 2], np.hypot(p[:, 0], p[:, 1])))
    azimuth = np.degrees(np.arctan2(p[:, 1], p[:, 0]))
    width = lidar.beam_half_width + np.degrees(np.arctan2(lidar.point_radius, rng))
    ring = np.round((elevation - lidar.lowest) / lidar.ring_step).astype(int)
    inside = (ring >= 0) & (ring < lidar.rings) & (np.abs(elevation - lidar.lowest - ring * lidar.ring_step) <= width)
    idx, rng, elevation, azimuth, width, ring = (v[inside] for v in (idx, rng, elevation, azimuth, width, ring))
    if len(idx) == 0:
        return idx, ring, ring, rng
    # A beam spans a few azimuth steps at most: try the nearest step and its neighbours on both sides.
    reach = int(np.ceil(width.max() / lidar.azimuth_step)) + 1
    nearest = np.round(azimuth / lidar.azimuth_step).astype(int)
    parts = []
    for k in range(-reach, reach + 1):
        step = nearest + k
        hit = np.abs(azimuth - step * lidar.azimuth_step) * np.cos(np.radians(elevation)) <= width
        parts.append((idx[hit], ring[hit], np.mod(step[hit], lidar.azimuth_cells), rng[hit]))
    return tuple(np.concatenate(v) for v in zip(*parts))


def resample(points, lidar, rng=None):
    """The sweep the lidar measures of ``points`` (in its frame): per (ring, azimuth step) the nearest point inside
    the beam (the first return), moved along its line of sight by range noise of lidar.range_sigma drawn from
    ``rng`` (none without it). The point keeps its place across the beam, so that a surface's shape is the
    cloud's, not widened by the beam at a silhouette. Returns the sweep (m x 3) and each return's ring and azimuth
    step."""
    idx, ring, step, dist = beam_cells(points, lidar)
    cell = ring.astype(np.int64) * lidar.azimuth_cells + step
    order = np.lexsort((dist, cell))
    first = order[np.r_[True, cell[order][1:] != cell[order][:-1]]] if len(order) else order
    sweep = points[idx[first]]
    if rng is not None and lidar.range_sigma > 0 and len(sweep):
        scale = 1.0 + rng.normal(0.0, lidar.range_sigma, len(sweep)) / dist[first]
        sweep = sweep * scale[:, None]
    return sweep, ring[first], step[first]


# --- The extractors ------------------------------------------------------------------------------------------------

def run_program(cmd):
    proc = atomic.run_child(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    if proc.returncode != 0:
        raise RuntimeError('%s failed (%d): %s' % (' '.join(cmd), proc.returncode, proc.stderr.strip()))


def read_summary(path):
    with open(path) as f:
        return {key: float(value) for key, value in (line.split() for line in f if line.strip())}


def read_rows(path):
    with open(path) as f:
        return [{k: (v if k == 'method' else float(v)) for k, v in row.items()} for row in csv.DictReader(f)]


def detect_sweep(pcd, work, lidar):
    """The per-sweep detector (config/trunk_extraction.yaml, the lidar's height) on a sweep file: the trunks as
    (x, y, dbh) rows and the detector's counts (DETECTOR_COUNTS)."""
    run_program([paths.program('cloud_trunks'), pcd, work, '--detector', 'sweep', '--config',
                 paths.package_file('config', 'trunk_extraction.yaml'), '--sensor-height', repr(lidar.height)])
    trunks = [(t['x'], t['y'], 2 * t['radius']) for t in read_rows(os.path.join(work, 'trunks.csv'))]
    summary = read_summary(os.path.join(work, 'summary.txt'))
    return trunks, {k: summary[k] for k in DETECTOR_COUNTS}


def find_sweep_stems(pcd, work, lidar):
    """The stem finder on a sweep file, given the sensor's position (the origin): the stems as (x, y, dbh) rows and
    the finder's counts (FINDER_COUNTS)."""
    run_program([paths.program('cloud_trunks'), pcd, work, '--sensor', '0,0,0'])
    stems = [(t['x'], t['y'], t['dbh']) for t in read_rows(os.path.join(work, 'stems.csv'))]
    summary = read_summary(os.path.join(work, 'summary.txt'))
    return stems, {k: summary[k] for k in FINDER_COUNTS}


def match(trunks, truth, gate=MATCH_GATE):
    """The index of the trunk (x, y, dbh) nearest ``truth`` (x, y) if within ``gate``, else None; and how many of
    the others there are (spurious)."""
    if not trunks:
        return None, 0
    d = [np.hypot(t[0] - truth[0], t[1] - truth[1]) for t in trunks]
    best = int(np.argmin(d))
    if d[best] > gate:
        return None, len(trunks)
    return best, len(trunks) - 1


def stem_band_points(sweep, distance, lidar, low=0.5, high=2.0, radius=0.5):
    """Returns within ``radius`` of the stem's axis (at x = distance in the sensor's frame) and ``low``..``high``
    above the ground: what the per-sweep detector's height band could hold of the stem."""
    near = np.hypot(sweep[:, 0] - distance, sweep[:, 1]) < radius
    height = sweep[:, 2] + lidar.height
    return int(np.count_nonzero(near & (height >= low) & (height <= high)))


# --- The benchmark ------------------------------------------------------------------------------------------------

def tree_sweeps(name, points, start, distances, bearings, lidar, seed, work, keep=None, progress=None):
    """Every sweep of one tree: its reference (dict) and one record per sweep and extractor (dicts)."""
    ground, centre, dbh, inliers, coverage = reference_fit(points, *start)
    reference = {'tree': name, 'ground': float(ground), 'x': float(centre[0]), 'y': float(centre[1]),
                 'dbh': float(dbh), 'points': int(inliers), 'coverage': float(coverage)}
    top = lidar.height + max(distances) * np.tan(np.radians(lidar.lowest + (lidar.rings - 1) * lidar.ring_step))
    sections = stem_sections(points, ground, centre, 0.5 * dbh, top + 0.5)
    records = []
    tree_seed = sum(ord(ch) for ch in name)  # the same noise for a tree whichever trees run with it
    for i, distance in enumerate(distances):
        for k in range(bearings):
            bearing = 2 * np.pi * k / bearings
            position, yaw = sensor_pose(centre, ground, distance, bearing, lidar)
            rng = np.random.default_rng([seed, tree_seed, int(round(1000 * distance)), k])
            seen = points[~behind_stem(points, position[:2], ground, sections)]
            sweep, ring, _ = resample(to_sensor(seen, position, yaw), lidar, rng)
            pcd = os.path.join(keep or work, '%s_%gm_%03d.pcd' % (name, distance, k))
            extract_trunks.write_pcd(pcd, sweep)
            base = {'tree': name, 'distance': distance, 'bearing_deg': round(float(np.degrees(bearing)), 3),
                    'returns': len(sweep), 'rings': len(np.unique(ring)),
                    'stem_band_returns': stem_band_points(sweep, distance, lidar)}
            for extractor, run in (('sweep', detect_sweep), ('stems', find_sweep_stems)):
                trunks, counts = run(pcd, work, lidar)
                best, spurious = match(trunks, (distance, 0.0))
                found = best is not None
                records.append(dict(base, extractor=extractor, found=found, spurious=spurious,
                                    dbh=trunks[best][2] if found else float('nan'),
                                    dbh_error=trunks[best][2] - dbh if found else float('nan'),
                                    centre_error=float(np.hypot(trunks[best][0] - distance, trunks[best][1]))
                                    if found else float('nan'), **counts))
            if keep is None:
                os.remove(pcd)
            if progress is not None:
                progress.update(1)
    return reference, records


def summarize(records, extractor):
    """Per (tree, distance), the figures of one extractor: sweeps, found share, spurious per sweep, the DBH
    error's median and worst (largest in size, signed), the centre error's median, and the mean of its counts."""
    counts = DETECTOR_COUNTS if extractor == 'sweep' else FINDER_COUNTS
    groups = collections.OrderedDict()
    for r in records:
        if r['extractor'] == extractor:
            groups.setdefault((r['tree'], r['distance']), []).append(r)
    rows = []
    for (tree, distance), rs in groups.items():
        errors = np.array([r['dbh_error'] for r in rs if r['found']])
        row = {'tree': tree, 'distance': distance, 'extractor': extractor, 'sweeps': len(rs),
               'found': float(np.mean([r['found'] for r in rs])),
               'spurious_per_sweep': float(np.mean([r['spurious'] for r in rs])),
               'dbh_error_median': float(np.median(errors)) if len(errors) else None,
               'dbh_error_worst': float(errors[np.argmax(np.abs(errors))]) if len(errors) else None,
               'centre_error_median': float(np.median([r['centre_error'] for r in rs if r['found']]))
               if len(errors) else None,
               'returns': float(np.median([r['returns'] for r in rs])),
               'rings': float(np.median([r['rings'] for r in rs])),
               'stem_band_returns': float(np.median([r['stem_band_returns'] for r in rs]))}
        for key in counts:
            row[key] = float(np.mean([r[key] for r in rs]))
        rows.append(row)
    return rows


def _cm(value):
    """A length in cm with its sign, '–' for none."""
    return '–' if value is None else '%+.1f' % (round(100 * value, 1) + 0.0)  # + 0.0: no -0.0


def report_lines(references, records):
    """The printed report: the references, the figures table and the counts tables (Markdown)."""
    lines = ['reference (a circle fitted to the full rings 1.25-1.35 m above the ground):']
    for ref in references:
        lines.append('  %s: ground %.3f m, stem at %.3f %.3f, DBH %.1f cm (%d points, %.0f %% of the ring)'
                     % (ref['tree'], ref['ground'], ref['x'], ref['y'], 100 * ref['dbh'], ref['points'],
                        100 * ref['coverage']))
    sweep, stems = summarize(records, 'sweep'), summarize(records, 'stems')
    lines += ['', '| tree | distance | returns per sweep | per-sweep detector: found | spurious per sweep | '
              'DBH error median / worst | stem finder: found | spurious per sweep | DBH error median / worst |',
              '|---|---|---|---|---|---|---|---|---|']
    for a, b in zip(sweep, stems):
        lines.append('| %s | %g m | %d | %.0f %% | %.2f | %s / %s cm | %.0f %% | %.2f | %s / %s cm |' % (
            a['tree'], a['distance'], a['returns'], 100 * a['found'], a['spurious_per_sweep'],
            _cm(a['dbh_error_median']), _cm(a['dbh_error_worst']), 100 * b['found'], b['spurious_per_sweep'],
            _cm(b['dbh_error_median']), _cm(b['dbh_error_worst'])))
    lines += ['', 'per-sweep detector (medians of the rings with returns and of the returns within 0.5 m of the stem '
              '0.5-2 m above the ground; the detector\'s counts as means per sweep):',
              '| tree | distance | rings | stem returns | band points | clusters | rejected: size | shape '
              '| radius | inliers | trunks |', '|---|---|---|---|---|---|---|---|---|---|---|']
    for a in sweep:
        lines.append('| %s | %g m | %d | %d | %.0f | %.1f | %.2f | %.2f | %.2f | %.2f | %.2f |' % (
            a['tree'], a['distance'], a['rings'], a['stem_band_returns'], a['band_points'], a['clusters'],
            a['rejected_size'], a['rejected_shape'], a['rejected_radius'], a['rejected_inliers'], a['trunks']))
    lines += ['', 'stem finder, means per sweep:', '| tree | distance | slice points | clusters | circles | columns | '
              'stems |', '|---|---|---|---|---|---|---|']
    for b in stems:
        lines.append('| %s | %g m | %.0f | %.1f | %.1f | %.2f | %.2f |' % (
            b['tree'], b['distance'], b['slice_points'], b['clusters'], b['circles'], b['columns'], b['stems']))
    return lines, {'references': references, 'sweep_detector': sweep, 'stem_finder': stems}


def write_records(path, records):
    keys = []
    for r in records:
        keys += [k for k in r if k not in keys]
    with atomic.atomic_output(path) as tmp:
        with open(tmp, 'w') as f:
            w = csv.DictWriter(f, fieldnames=keys, restval='', lineterminator='\n')
            w.writeheader()
            for r in records:
                w.writerow({k: ('%.4f' % v if isinstance(v, float) else v) for k, v in r.items()})


# --- The command ------------------------------------------------------------------------------------------------

def numbers(text):
    try:
        values = [float(v) for v in text.split(',')]
    except ValueError:
        values = []
    if not values or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError('expected numbers separated by commas, got %r' % text)
    return values


def parse_args(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('--data', metavar='DIR', help='the directory holding the data sets (default: $%s); the trees in '
                   'DIR/treels' % paths.DATA_ENV)
    p.add_argument('--trees', default=','.join(TREES), help='of the data folder, by name (default: %(default)s)')
    p.add_argument('--cloud', metavar='TREE.pcd', help='another cloud of one tree, instead of the data folder\'s')
    p.add_argument('--stem', metavar='X,Y,R', type=numbers, help='with --cloud: a start for its reference fit')
    p.add_argument('--distances', metavar='D,...', type=numbers, default=[3.0, 6.0, 9.0],
                   help='sensor to stem [m] (default: 3,6,9)')
    p.add_argument('--bearings', type=int, default=24, help='sweeps per distance, evenly around the tree')
    p.add_argument('--seed', type=int, default=1, help='of the range noise')
    p.add_argument('--range-sigma', metavar='M', type=float, default=0.02,
                   help='the range noise\'s standard deviation [m] (default: %(default)s)')
    p.add_argument('--out', metavar='DIR', help='write DIR/sweeps.csv and DIR/summary.json')
    p.add_argument('--keep-sweeps', action='store_true', help='with --out: the sweeps as DIR/sweeps/*.pcd')
    args = p.parse_args(argv)
    if (args.cloud is None) != (args.stem is None) or (args.stem is not None and len(args.stem) != 3):
        p.error('--cloud and --stem X,Y,R go together')
    if args.bearings < 1 or min(args.distances) <= 0 or not args.range_sigma >= 0:
        p.error('--bearings must be at least 1, the distances positive and --range-sigma not negative')
    if args.keep_sweeps and not args.out:
        p.error('--keep-sweeps needs --out')
    return args


def tree_clouds(args):
    """(name, points, start) of each tree to run."""
    if args.cloud:
        if not os.path.isfile(args.cloud):
            raise atomic.UserError('%s: no such file' % args.cloud)
        name = os.path.splitext(os.path.basename(args.cloud))[0]
        return [(name, read_pcd(args.cloud), tuple(args.stem))]
    names = [n for n in args.trees.split(',') if n]
    unknown = [n for n in names if n not in TREES]
    if unknown or not names:
        raise atomic.UserError('--trees: unknown tree %s (the data folder holds %s)'
                               % (','.join(unknown), ', '.join(TREES)))
    folder = paths.data_dir(args.data, 'treels')
    clouds = []
    for name in names:
        path = os.path.join(folder, name + '.pcd')
        if not os.path.isfile(path):
            raise atomic.UserError('%s: no such file' % path)
        clouds.append((name, read_pcd(path), TREES[name]))
    return clouds


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr for missing data or a failing program; 2 for a wrong
    command line."""
    return atomic.run_tool(PROG, _main, argv, errors=(ValueError, RuntimeError))


def _main(argv):
    args = parse_args(argv)
    paths.program('cloud_trunks')  # a missing build is one line before any work
    clouds = tree_clouds(args)
    keep = None
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        if args.keep_sweeps:
            keep = os.path.join(args.out, 'sweeps')
            os.makedirs(keep, exist_ok=True)
    from tqdm import tqdm
    lidar = Lidar(range_sigma=args.range_sigma)
    references, records = [], []
    with tempfile.TemporaryDirectory(prefix=PROG + '.') as work, \
            tqdm(total=len(clouds) * len(args.distances) * args.bearings, desc=PROG, unit='sweep', disable=None,
                 leave=False) as bar:
        for name, points, start in clouds:
            ref, recs = tree_sweeps(name, points, start, args.distances, args.bearings, lidar, args.seed, work,
                                    keep, bar)
            references.append(ref)
            records += recs
    lines, summary = report_lines(references, records)
    print('\n'.join(lines))
    if args.out:
        write_records(os.path.join(args.out, 'sweeps.csv'), records)
        summary['command'] = {'distances': args.distances, 'bearings': args.bearings, 'seed': args.seed,
                              'lidar': vars(lidar)}
        atomic.write_json(os.path.join(args.out, 'summary.json'), summary, indent=2)
    return 0
