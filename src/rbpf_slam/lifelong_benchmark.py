"""A second visit to a mapped stand: relocalization in the saved tree map from an unknown start, then tracking.

Per world and seed:
  1. visit 1: record_scenario drives the loop (--drive; seed S; the driver steers on the true pose, as a person
     would, so that the loop keeps clear of the trunks; the straight drive where the loop collides, is refused
     before it starts or is not finished in time) and slam_bag --save-map keeps the tree map (its frame: the
     start of visit 1);
  2. the stand changes: --fell of the trees are felled, --plant as many new ones planted (at least 1.5 m from any
     trunk), every other tree grows by 0..--grow m of radius;
  3. visit 2: the robot starts at a random pose inside the stand (random heading; a start whose drive would touch
     a trunk is drawn again) and drives --length metres straight ahead; slam_bag --map searches the saved map for
     it (no start pose given) and then tracks in it.
Printed per run and as median / worst over the seeds: whether and after how much travel the robot was found, the
position error at that instant and over the rest of the drive (median) against the truth carried into the saved
map's frame, the search's CPU time, and beside them the same run's dead reckoning (the odometry's final error
from its own start: what a robot without the map would carry). A relocalization counts as wrong when its error
exceeds --wrong metres. Only the evaluator reads the truth.

Example:
  rosrun rbpf_slam lifelong_benchmark --worlds paper_forest,clumped --seeds 1-20 --out lifelong_out
Exit code 0; 1 with one line on stderr on a missing input or a failed run.
"""
import argparse
import json
import math
import os
import random
import re
import subprocess
import sys
import tempfile

from rbpf_slam import paths
from rbpf_slam.evaluate import read_landmarks_csv, read_tum


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


def parse_seeds(text):
    out = []
    for part in text.split(','):
        if '-' in part:
            a, b = part.split('-')
            out += list(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def read_trees(path):
    trees = []
    with open(path) as f:
        for line in f:
            line = line.split('#')[0].split()
            if len(line) >= 3:
                trees.append([float(v) for v in line])
    return trees


def tree_list_of(world):
    """The tree list of @p world: a world file's "trees:" file, or the world itself when it is a plain tree list
    (x y radius per line, # comments; the simulator takes it as a flat world). (path, world text, the "trees:"
    match or None). ValueError for a file that is neither, naming its first line that is no tree."""
    try:
        with open(world) as f:
            text = f.read()
    except UnicodeDecodeError:
        raise ValueError('%s: neither a world file nor a tree list: not text' % world)
    m = re.search(r'^trees:\s*(\S+)', text, re.M)
    if m:
        return os.path.join(os.path.dirname(world), m.group(1)), text, m
    trees = 0
    for number, line in enumerate(text.splitlines(), 1):
        fields = line.split('#')[0].split()
        if not fields:
            continue
        try:
            values = [float(v) for v in fields]
        except ValueError:
            values = []
        if len(values) < 3:
            raise ValueError('%s:%d: neither a world file (no "trees:" line) nor a tree list (x y radius per line)'
                             % (world, number))
        trees += 1
    if trees == 0:
        raise ValueError('%s: neither a world file (no "trees:" line) nor a tree list (no tree in it)' % world)
    return world, text, None


def changed_world(world, out_dir, rng, fell, plant, grow):
    """A copy of the world whose tree list has been felled, planted and grown; (path, bounds, felled, planted). A
    plain tree list gives a plain tree list."""
    tree_path, text, m = tree_list_of(world)
    trees = read_trees(tree_path)
    n_fell = int(round(fell * len(trees)))
    felled = set(rng.sample(range(len(trees)), n_fell))
    kept = [list(t) for i, t in enumerate(trees) if i not in felled]
    for t in kept:
        t[2] += rng.uniform(0.0, grow)
    xs = [t[0] for t in trees]
    ys = [t[1] for t in trees]
    planted = []
    tries = 0
    while len(planted) < int(round(plant * len(trees))) and tries < 10000:
        tries += 1
        x, y = rng.uniform(min(xs), max(xs)), rng.uniform(min(ys), max(ys))
        if all(math.hypot(x - t[0], y - t[1]) > 1.5 + t[2] for t in kept + planted):
            planted.append([x, y, rng.uniform(0.05, 0.12)])
    tree_file = os.path.join(out_dir, 'visit2.trees.txt')
    with open(tree_file, 'w') as f:
        f.write('# x y radius: the stand of %s after %d felled, %d planted, growth up to %.3f m\n'
                % (os.path.basename(world), len(felled), len(planted), grow))
        for t in kept + planted:
            f.write('%.3f %.3f %.3f %s\n' % (t[0], t[1], t[2], ' '.join('%.3f' % v for v in t[3:])))
    if m is None:
        world2 = tree_file
    else:
        world2 = os.path.join(out_dir, 'visit2.yaml')
        with open(world2, 'w') as f:
            f.write(text[:m.start(1)] + 'visit2.trees.txt' + text[m.end(1):])
    return world2, (min(xs), min(ys), max(xs), max(ys)), [trees[i][:2] for i in sorted(felled)], \
        [t[:2] for t in planted]


def world_trees_file(world):
    """The tree list a world file names (the world itself for a plain tree list)."""
    return tree_list_of(world)[0]


def truth_and_odometry(bag_path):
    import rosbag
    from rbpf_slam.geometry import yaw_of
    out = {'/ground_truth/odom': [], '/odom': []}
    with rosbag.Bag(bag_path) as bag:
        for topic, msg, _ in bag.read_messages(topics=list(out)):
            p = msg.pose.pose
            q = p.orientation
            yaw = float(yaw_of([[q.x, q.y, q.z, q.w]])[0])
            out[topic].append((msg.header.stamp.to_sec(), p.position.x, p.position.y, yaw))
    return out['/ground_truth/odom'], out['/odom']


def jump_odometry(bag_in, bag_out, jump, at):
    """A copy of @bag_in whose wheel odometry (/odom) jumps by jump = (dx, dy, dyaw) [m, m, rad] once it has
    travelled @at metres (a slip or a reset the robot did not make): later poses are o_at * jump * o_at^-1 * o."""
    import rosbag
    from rbpf_slam.geometry import yaw_of
    travel, last, o_at = 0.0, None, None
    with rosbag.Bag(bag_in) as src, rosbag.Bag(bag_out, 'w') as dst:
        for topic, msg, t in src.read_messages():
            if topic == '/odom':
                p = msg.pose.pose
                q = p.orientation
                pose = (p.position.x, p.position.y, float(yaw_of([[q.x, q.y, q.z, q.w]])[0]))
                if last is not None:
                    travel += math.hypot(pose[0] - last[0], pose[1] - last[1])
                last = pose
                if o_at is None and travel >= at:
                    o_at = pose
                if o_at is not None:
                    moved = compose(compose(compose(o_at, jump), inverse(o_at)), pose)
                    p.position.x, p.position.y = moved[0], moved[1]
                    p.orientation.z, p.orientation.w = math.sin(moved[2] / 2.0), math.cos(moved[2] / 2.0)
                    p.orientation.x = p.orientation.y = 0.0
            dst.write(topic, msg, t)
    return o_at is not None


def nearest(samples, t):
    lo, hi = 0, len(samples) - 1
    while lo < hi:
        mid = (lo + hi) // 2
        if samples[mid][0] < t:
            lo = mid + 1
        else:
            hi = mid
    best = min((abs(samples[k][0] - t), k) for k in (lo - 1, lo) if 0 <= k < len(samples))
    return samples[best[1]]


def world_to_map(start1, xy):
    return compose(inverse(start1), (xy[0], xy[1], 0.0))[:2]


def score_changes(csv_path, map1, felled_xy, planted_xy, start1, truth, to_map, path1, world_trees, args):
    """Felled and new trees reported against the truth. A felled tree counts when the saved map held it (a
    confirmed tree within --gate) and visit 2 had its place inside 1 m .. --scope and not behind a standing trunk for
    1 s of its drive ('felled_eligible_any': visit 2 passed within --scope of it); a planted one when both visits passed
    within --scope of its place (@p path1: visit 1's true path in the map frame; a place visit 1 never saw cannot
    be known to have changed). 'new_eligible_any' counts those visit 2 passed, visit 1 or not. A reported radius
    change is set beside the true growth of the tree it stands for (@p world_trees: the stand before the visits)."""
    from rbpf_slam.evaluate import read_landmarks_csv
    import csv
    saved = read_landmarks_csv(map1)
    saved_xy = [(x, y) for x, y, p in zip(saved['x'], saved['y'], saved['provisional']) if not p]
    path = [compose(to_map, t[1:])[:2] for t in truth[::10]]

    def near_path(p, along=path):
        return any(math.hypot(p[0] - q[0], p[1] - q[1]) <= args.scope for q in along)

    def near(p, pts):
        return any(math.hypot(p[0] - q[0], p[1] - q[1]) <= args.gate for q in pts)
    felled = [world_to_map(start1, f) for f in felled_xy]
    kept_trees = read_trees(os.path.join(os.path.dirname(map1), 'visit2.trees.txt'))
    kept = [world_to_map(start1, t[:2]) for t in kept_trees]
    before = {(round(t[0], 3), round(t[1], 3)): t[2] for t in read_trees(world_trees)}

    def true_growth(p):
        """[m] how much the radius of the kept tree nearest @p p (within --gate) grew; None: no such tree."""
        best = min(((math.hypot(p[0] - q[0], p[1] - q[1]), t) for q, t in zip(kept, kept_trees)), default=None)
        if best is None or best[0] > args.gate:
            return None
        r0 = before.get((round(best[1][0], 3), round(best[1][1], 3)))
        return None if r0 is None else best[1][2] - r0
    planted = [world_to_map(start1, f) for f in planted_xy]
    # Visit 2's true path at about the sweeps' 10 Hz, and the trunks standing then (kept and planted): a felled tree
    # is expected to be missed where it was inside 1 m .. --scope and not behind a standing trunk.
    dt = (truth[-1][0] - truth[0][0]) / max(1, len(truth) - 1)
    views = [compose(to_map, t[1:])[:2] for t in truth[::max(1, int(round(0.1 / dt))) if dt > 0 else 1]]
    standing = [(q[0], q[1], t[2]) for q, t in zip(kept, kept_trees)]

    def sweeps_in_clear_view(p, r):
        n = 0
        for v in views:
            rng = math.hypot(p[0] - v[0], p[1] - v[1])
            if rng < 1.0 or rng > args.scope:
                continue
            bearing = math.atan2(p[1] - v[1], p[0] - v[0])
            hidden = False
            for x, y, rf in standing:
                front = math.hypot(x - v[0], y - v[1])
                if 1e-6 < front < rng - (r + rf + 0.1):
                    d = math.atan2(y - v[1], x - v[0]) - bearing
                    if abs(math.atan2(math.sin(d), math.cos(d))) < (rf + 0.15) / front:
                        hidden = True
                        break
            n += not hidden
        return n
    felled_radius = [before.get((round(f[0], 3), round(f[1], 3)), 0.1) for f in felled_xy]
    eligible_any_felled = [f for f in felled if near(f, saved_xy) and near_path(f)]
    # the filter removes a saved tree after about 8 sweeps of expected misses: 1 s in the clear counts
    eligible_felled = [f for f, r in zip(felled, felled_radius)
                       if near(f, saved_xy) and sweeps_in_clear_view(f, r) >= 10]
    eligible_any = [f for f in planted if near_path(f)]
    eligible_new = [f for f in eligible_any if near_path(f, path1)]
    reported = {'felled': [], 'new': [], 'changed': []}
    grown = []  # reported radius changes: (reported, true) [m] of radius
    with open(csv_path) as f:
        for row in csv.DictReader(f):
            xy = (float(row['x']), float(row['y']))
            reported[row['kind']].append(xy)
            if row['kind'] == 'changed':
                true = true_growth(xy)
                if true is not None:
                    grown.append((0.5 * (float(row['dbh_after']) - float(row['dbh_before'])), true))
    return {
        'felled_eligible': len(eligible_felled),
        'felled_found': sum(1 for f in eligible_felled if near(f, reported['felled'])),
        'felled_eligible_any': len(eligible_any_felled),
        'felled_found_any': sum(1 for f in eligible_any_felled if near(f, reported['felled'])),
        'felled_reported': len(reported['felled']),
        'felled_true': sum(1 for r in reported['felled'] if near(r, felled)),
        'new_eligible': len(eligible_new),
        'new_found': sum(1 for f in eligible_new if near(f, reported['new'])),
        'new_eligible_any': len(eligible_any),
        'new_found_any': sum(1 for f in eligible_any if near(f, reported['new'])),
        'new_reported': len(reported['new']),
        'new_true': sum(1 for r in reported['new'] if near(r, planted)),
        # reported new where a tree stood before that visit 1 never mapped: new to the map, not planted
        'new_unmapped': sum(1 for r in reported['new'] if not near(r, planted) and near(r, kept)
                            and not near(r, saved_xy)),
        'changed_reported': len(reported['changed']),
        # radius changes: the growth reported against the tree's true growth
        'changed_pairs': grown,
    }


def geo_to_en(lat0, lon0, alt0, lat, lon):
    """[m] east, north of (lat, lon) [deg] in the tangent plane at (lat0, lon0, alt0), as the package computes it."""
    a, f = 6378137.0, 1.0 / 298.257223563
    e2 = f * (2.0 - f)
    s = math.sin(math.radians(lat0))
    w = math.sqrt(1.0 - e2 * s * s)
    meridian = a * (1.0 - e2) / w ** 3 + alt0
    parallel = (a / w + alt0) * math.cos(math.radians(lat0))
    return (math.radians(lon - lon0) * parallel, math.radians(lat - lat0) * meridian)


def anchor_errors(anchor, start1, trees_map, args):
    """The saved map's anchor against the truth: [m] origin error, [deg] heading error, [m] median and largest
    error of the trees' georeferenced positions (each true tree's map position placed on the earth by the saved
    anchor and by the true one), all in the tangent plane at the world's origin."""
    wy = math.radians(args.world_yaw)
    c, s = math.cos(wy), math.sin(wy)
    true_origin = (c * start1[0] - s * start1[1], s * start1[0] + c * start1[1])
    true_yaw = wy + start1[2]
    est_origin = geo_to_en(GPS_ORIGIN[0], GPS_ORIGIN[1], GPS_ORIGIN[2], anchor['latitude'], anchor['longitude'])
    est_yaw = anchor['yaw']

    def place(origin, yaw, p):
        cy, sy = math.cos(yaw), math.sin(yaw)
        return (origin[0] + cy * p[0] - sy * p[1], origin[1] + sy * p[0] + cy * p[1])
    errors = sorted(math.hypot(*(u - v for u, v in zip(place(est_origin, est_yaw, p), place(true_origin, true_yaw, p))))
                    for p in trees_map)
    dyaw = math.degrees(math.atan2(math.sin(est_yaw - true_yaw), math.cos(est_yaw - true_yaw)))
    return {'origin': math.hypot(est_origin[0] - true_origin[0], est_origin[1] - true_origin[1]), 'yaw_deg': dyaw,
            'trees_median': errors[len(errors) // 2] if errors else float('nan'),
            'trees_max': errors[-1] if errors else float('nan'), 'sigma': anchor.get('sigma', float('nan'))}


#: WGS84 latitude, longitude [deg] and altitude [m] of the worlds' origin with --gps (the simulator's default).
GPS_ORIGIN = (47.0, 8.0, 500.0)
# record_scenario's exit statuses (rbpf_slam::sim::exit_status): the robot ran into a trunk, the drive was refused
# before it started, the drive was not finished in time
COLLIDED, REFUSED, TIMED_OUT = 3, 4, 5


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    return r.returncode, r.stdout + r.stderr


def one_run(args, world, seed, work):
    record, slam_bag = paths.program('record_scenario'), paths.program('slam_bag')
    start1 = (0.0, 15.0, 0.0)  # the simulator's default start, where the straight drive begins
    bag1 = os.path.join(work, 'visit1.bag')
    map1 = os.path.join(work, 'visit1_map.csv')
    sim1 = os.path.join(work, 'visit1_sim.yaml')
    gps = ('gps: {enabled: true, world_yaw_deg: %.3f, origin: {latitude: %.6f, longitude: %.6f, altitude: %.3f}}\n'
           % ((args.world_yaw,) + GPS_ORIGIN)) if args.gps else ''
    with open(sim1, 'w') as f:  # a driver who sees the track: the loop keeps its distance from every trunk
        f.write('follower: {speed: 1.0, lookahead: 2.0, max_angular: 0.8, goal_tolerance: 0.3, steer_on: truth}\n')
        f.write(gps)
    sim2 = os.path.join(work, 'visit2_sim.yaml')
    with open(sim2, 'w') as f:
        f.write(gps)
    code, out = run([record, '--world', world, '--drive', args.drive, '--seed', str(seed), '--out', bag1,
                     '--config', sim1, '--quiet'])
    if code in (COLLIDED, REFUSED, TIMED_OUT) and args.drive != 'straight':
        # the loop runs into a trunk, is refused before it starts or is not finished in time: the straight drive
        code, out = run([record, '--world', world, '--drive', 'straight', '--seed', str(seed), '--out', bag1,
                         '--config', sim1, '--quiet'])
    if code != 0:
        return {'error': 'visit 1: ' + out.strip().splitlines()[-1]}
    code, out = run([slam_bag, '--bag', bag1, '--seed', str(seed), '--quiet', '--save-map', map1] +
                    sum((['--config', c] for c in args.config), []))
    if code != 0:
        return {'error': 'visit 1 SLAM: ' + out.strip().splitlines()[-1]}
    rng = random.Random(seed * 7919 + 17)
    world2, box, felled_xy, planted_xy = changed_world(world, work, rng, args.fell, args.plant, args.grow)
    drive = os.path.join(work, 'visit2_drive.txt')
    with open(drive, 'w') as f:
        for k in range(1, int(args.length // 5) + 1):
            f.write('%.1f 0\n' % (5.0 * k))
    bag2 = os.path.join(work, 'visit2.bag')
    for attempt in range(40):
        start2 = (rng.uniform(box[0] + 2, box[2] - 2), rng.uniform(box[1] + 2, box[3] - 2),
                  rng.uniform(-math.pi, math.pi))
        code, out = run([record, '--world', world2, '--drive', drive, '--seed', str(seed), '--quiet', '--out', bag2,
                         '--config', sim2, '--start', '%.3f' % start2[0], '%.3f' % start2[1], '%.3f' % math.degrees(start2[2])])
        if code == 0:
            break
        if code not in (COLLIDED, REFUSED):  # a start beside a trunk: drawn again
            return {'error': 'visit 2: ' + out.strip().splitlines()[-1]}
    else:
        return {'error': 'visit 2: no start without a collision in 40 draws'}
    if args.jump:
        jumped = os.path.join(work, 'visit2_jump.bag')
        if not jump_odometry(bag2, jumped, (args.jump[0], args.jump[1], math.radians(args.jump[2])), args.jump[3]):
            return {'error': 'visit 2: the drive is shorter than --jump\'s %.1f m' % args.jump[3]}
        bag2 = jumped
    out_dir = os.path.join(work, 'visit2_run')
    map2 = os.path.join(work, 'visit2_map.csv')
    changes = os.path.join(work, 'visit2_map_changes')  # written beside the saved map
    code, out = run([slam_bag, '--bag', bag2, '--seed', str(seed), '--map', map1, '--out', out_dir,
                     '--save-map', map2] + sum((['--config', c] for c in args.config), []))
    truth, odom = truth_and_odometry(bag2)
    to_map = compose(inverse(start1), start2)  # visit 2's start frame -> the saved map's frame
    res = {'world': os.path.basename(world), 'seed': seed, 'felled': len(felled_xy), 'planted': len(planted_xy),
           'start': start2, 'attempts': attempt + 1}
    lost = re.search(r'searched again (\d+) times while tracking: (\d+) found the robot elsewhere', out)
    res['lost_searches'], res['recoveries'] = (int(lost.group(1)), int(lost.group(2))) if lost else (0, 0)
    if args.gps:
        trees_map = [world_to_map(start1, t[:2]) for t in read_trees(world_trees_file(world))]
        anchor1 = read_landmarks_csv(map1)['anchor']
        res['anchor1'] = anchor_errors(anchor1, start1, trees_map, args) if anchor1 else None
    o_end = odom[-1]
    # Dead reckoning: the odometry from its own start against the truth from the same start (no map).
    o0, t0 = odom[0], truth[0]
    o_rel = compose(inverse(o0[1:]), o_end[1:])
    t_rel = compose(inverse(t0[1:]), nearest(truth, o_end[0])[1:])
    res['dead_reckoning'] = math.hypot(o_rel[0] - t_rel[0], o_rel[1] - t_rel[1])
    m = re.search(r'relocalized in the saved map at ([0-9.]+) s after ([0-9.]+) m of travel and (\d+) sweeps of '
                  r'search: (\d+) of (\d+) trunks explained, particles over (\d+) hypotheses; search time ([0-9.]+) s '
                  r'in all, ([0-9.]+) s at most', out)
    if code != 0 or not m:
        res.update(found=False, reason=out.strip().splitlines()[-1] if out.strip() else 'exit %d' % code)
        return res
    res.update(found=True, found_stamp=float(m.group(1)), travel=float(m.group(2)), sweeps=int(m.group(3)),
               inliers=int(m.group(4)), trunks=int(m.group(5)), hypotheses=int(m.group(6)),
               search_seconds=float(m.group(7)), search_max=float(m.group(8)),
               found_after=float(m.group(1)) - truth[0][0])
    stamps, xy, _ = read_tum(os.path.join(out_dir, 'estimate.tum'))
    errors = []
    for t, (x, y) in zip(stamps, xy):
        tr = nearest(truth, t)
        p = compose(to_map, tr[1:])
        errors.append(math.hypot(x - p[0], y - p[1]))
    res['error_found'] = errors[0]
    # The saved map's own error around where visit 2 was found: each confirmed saved tree within --scope of the
    # true pose there against the nearest true tree (within 3 m); the mean offset is what a pose right among those
    # trees is off in the map's frame. The pose error less that offset: the error against the trees around.
    tr = compose(to_map, nearest(truth, stamps[0])[1:])
    saved = read_landmarks_csv(map1)
    stand1 = [world_to_map(start1, t[:2]) for t in read_trees(world_trees_file(world))]
    offsets = []
    for x, y, prov in zip(saved['x'], saved['y'], saved['provisional']):
        if prov or math.hypot(x - tr[0], y - tr[1]) > args.scope:
            continue
        d, q = min((math.hypot(x - q[0], y - q[1]), q) for q in stand1)
        if d <= 3.0:
            offsets.append((x - q[0], y - q[1]))
    if offsets:
        off = (sum(o[0] for o in offsets) / len(offsets), sum(o[1] for o in offsets) / len(offsets))
        res['map_offset'] = math.hypot(*off)
        res['error_local'] = math.hypot(xy[0][0] - tr[0] - off[0], xy[0][1] - tr[1] - off[1])
    res['error_median'] = sorted(errors)[len(errors) // 2]
    res['error_final'] = errors[-1]
    res['wrong'] = errors[0] > args.wrong
    back = re.search(r'moved the particles there \(at ([0-9.]+) s', out)
    if back:  # found again after lost tracking: where it was, and the error over the next 5 s
        t_back = float(back.group(1))
        after = [e for t, e in zip(stamps, errors) if t_back < t <= t_back + 5.0]
        res['recovered_at'] = t_back
        res['error_recovered'] = sorted(after)[len(after) // 2] if after else float('nan')
    truth1, _ = truth_and_odometry(bag1)  # in visit 1's start frame: the saved map's
    path1 = [t[1:3] for t in truth1[::10]]
    world_trees = world_trees_file(world)
    res.update(score_changes(changes + '.csv', map1, felled_xy, planted_xy, start1, truth, to_map, path1, world_trees,
                             args))
    if args.gps:
        anchor2 = read_landmarks_csv(map2)['anchor'] if os.path.isfile(map2) else None
        res['anchor2'] = anchor_errors(anchor2, start1, trees_map, args) if anchor2 else None
    return res


def write_report(path, args, results, summary, argv=None):
    """A Markdown page of the runs: what was done, a line per run, the summaries (atomically); @p argv: the
    command line's arguments (default: this process's)."""
    lines = ['# Second visit', '',
             'Visit 1 maps the stand (the loop) and saves the tree map; then %.0f %% of the trees are felled, %.0f %% '
             'planted and every other grows by up to %.0f mm of radius; visit 2 starts at a random pose and heading '
             'inside the stand with no start pose given, drives %.0f m straight, finds itself in the saved map from '
             'the trunks and reports what changed.%s Errors are against the truth carried into the saved map\'s frame; '
             'dead reckoning is the same drive\'s odometry from its own start.'
             % (100 * args.fell, 100 * args.plant, 1000 * args.grow, args.length,
                ' Both visits carry the simulator\'s satellite receiver: the saved map\'s anchor on the earth is '
                'scored against the truth (its trees placed on the earth by the fitted anchor and by the true one).'
                if args.gps else ''), '',
             '| stand | seed | found after [m] | error there [m] | median error [m] | dead reckoning [m] | felled '
             'found / reported true | new found / reported true |%s' % (' anchor: trees off [m] |' if args.gps else ''),
             '|---|---|---|---|---|---|---|---|%s' % ('---|' if args.gps else '')]
    for r in results:
        name = os.path.splitext(r['world'])[0]
        if 'error' in r or not r.get('found'):
            lines.append('| %s | %d | %s | | | | | |%s' % (name, r['seed'], r.get('error') or 'not found: ' +
                                                           r.get('reason', ''), ' |' if args.gps else ''))
            continue
        a = r.get('anchor1')
        lines.append('| %s | %d | %.1f | %.3f%s | %.3f | %.2f | %d of %d / %d of %d | %d of %d / %d of %d |%s'
                     % (name, r['seed'], r['travel'], r['error_found'], ' (wrong)' if r['wrong'] else '',
                        r['error_median'], r['dead_reckoning'], r['felled_found'], r['felled_eligible'],
                        r['felled_true'], r['felled_reported'], r['new_found'], r['new_eligible'], r['new_true'],
                        r['new_reported'], (' %.2f |' % a['trees_median'] if a else ' none |') if args.gps else ''))
    lines += ['', '## Over the seeds', ''] + ['- ' + line for line in summary] + [
        '', 'Reproduce: `rosrun rbpf_slam lifelong_benchmark %s`'
        % ' '.join(sys.argv[1:] if argv is None else argv), '']
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    tmp = os.path.join(folder, '.' + os.path.basename(path) + '.tmp')
    with open(tmp, 'w') as f:
        f.write('\n'.join(lines))
    os.replace(tmp, path)


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr on a missing input."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0], epilog=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--worlds', default='paper_forest,clumped,plantation_rows,dense_forest,sparse_stand',
                    help='world files of config/worlds (names) or paths, comma-separated; a path may be a plain '
                         'tree list (x y radius per line), a flat world')
    ap.add_argument('--seeds', default='1-10', help='e.g. 1-20 or 1,4,9')
    ap.add_argument('--drive', default='loop',
                    help='the first visit\'s drive: loop (the default; straight where the loop collides, is '
                         'refused or times out)')
    ap.add_argument('--fell', type=float, default=0.10, help='share of the trees felled between the visits')
    ap.add_argument('--plant', type=float, default=0.05, help='share of new trees planted between the visits')
    ap.add_argument('--grow', type=float, default=0.01, help='[m] most radius growth between the visits')
    ap.add_argument('--length', type=float, default=15.0, help='[m] of the second visit\'s straight drive')
    ap.add_argument('--wrong', type=float, default=1.0, help='[m] a relocalization farther off is wrong')
    ap.add_argument('--scope', type=float, default=10.0,
                    help='[m] a change counts when the second visit\'s path came this close to it')
    ap.add_argument('--gate', type=float, default=0.5, help='[m] a reported change matches a true one this close')
    ap.add_argument('--config', action='append', default=[],
                    help='FastSLAM parameter file for both visits (repeatable, as slam_bag --config)')
    ap.add_argument('--gps', action='store_true',
                    help='both visits with the simulator\'s satellite receiver (config/forest_sim.yaml gps defaults): '
                         'the saved maps\' anchors are scored against the truth')
    ap.add_argument('--world-yaw', type=float, default=30.0,
                    help='[deg] with --gps: heading of the world\'s x axis from east')
    ap.add_argument('--jump', type=float, nargs=4, metavar=('DX', 'DY', 'DYAW_DEG', 'AT_M'),
                    help='visit 2\'s wheel odometry jumps by DX, DY [m] and DYAW_DEG once it has travelled AT_M metres '
                         '(a slip or a reset): tracking is lost and must be found again (use a --length beyond AT_M)')
    ap.add_argument('--report', default='',
                    help='also write a one-page Markdown report of the runs here (written whole, then renamed)')
    ap.add_argument('--out', default='', help='folder for lifelong.json (and the runs\' files with --keep)')
    ap.add_argument('--keep', action='store_true', help='keep every run\'s bags and outputs under --out')
    args = ap.parse_args(argv)
    try:
        worlds = [w if os.path.isfile(w) else paths.package_file('config', 'worlds', w + '.yaml')
                  for w in args.worlds.split(',')]
        for w in worlds:
            if not os.path.isfile(w):
                raise ValueError('%s: no such world file' % w)
            tree_list_of(w)  # a world file or a plain tree list, before any run
        seeds = parse_seeds(args.seeds)
        paths.program('slam_bag')
    except ValueError as e:
        print('lifelong_benchmark: %s' % e, file=sys.stderr)
        return 1
    results = []
    summary = []

    def say(line):
        print(line)
        summary.append(line)
    for world in worlds:
        name = os.path.splitext(os.path.basename(world))[0]
        for seed in seeds:
            if args.keep and args.out:
                work = os.path.join(args.out, '%s_seed%d' % (name, seed))
                os.makedirs(work, exist_ok=True)
                r = one_run(args, world, seed, work)
            else:
                with tempfile.TemporaryDirectory(prefix='lifelong_') as work:
                    r = one_run(args, world, seed, work)
            r.setdefault('world', os.path.basename(world))
            r.setdefault('seed', seed)
            results.append(r)
            if 'error' in r:
                print('%-16s seed %2d: %s' % (name, seed, r['error']))
            elif not r['found']:
                print('%-16s seed %2d: not found (%s); dead reckoning %.2f m' % (name, seed, r['reason'],
                                                                               r['dead_reckoning']))
            else:
                print('%-16s seed %2d: found after %.1f m (%d sweeps, %d of %d trunks, %d hypotheses, search %.3f s, '
                      'max %.3f s/sweep): error %.3f m there, %.3f m median, %.3f m final%s; dead reckoning %.2f m%s'
                      % (name, seed, r['travel'], r['sweeps'], r['inliers'], r['trunks'], r['hypotheses'],
                         r['search_seconds'], r['search_max'], r['error_found'], r['error_median'],
                         r['error_final'], ' WRONG' if r['wrong'] else '', r['dead_reckoning'],
                         '; searched again %d times while tracking, %d moved the particles%s'
                         % (r['lost_searches'], r['recoveries'],
                            ' (error over the 5 s after: %.3f m)' % r['error_recovered'] if 'error_recovered' in r
                            else '') if r['lost_searches'] else ''))
                if 'error_local' in r:
                    print('%-16s          the saved trees around there %.2f m off; the pose against them %.3f m'
                          % ('', r['map_offset'], r['error_local']))
                print('%-16s          felled: %d of %d found, %d of %d reported true; new: %d of %d found, %d of %d '
                      'reported true (%d unmapped before); %d radii changed'
                      % ('', r['felled_found'], r['felled_eligible'], r['felled_true'], r['felled_reported'],
                         r['new_found'], r['new_eligible'], r['new_true'], r['new_reported'], r['new_unmapped'],
                         r['changed_reported']))
            if args.gps and 'error' not in r:
                for key, what in (('anchor1', 'visit 1 anchor'), ('anchor2', 'visit 2 anchor')):
                    a = r.get(key)
                    if a:
                        print('%-16s          %s: trees placed %.2f m off (median; %.2f m at most), origin %.2f m, '
                              'heading %+.2f deg, stated sigma %.2f m' % ('', what, a['trees_median'], a['trees_max'],
                                                                          a['origin'], a['yaw_deg'], a['sigma']))
                    elif key in r or key == 'anchor1':
                        print('%-16s          %s: none' % ('', what))
            sys.stdout.flush()
        rs = [r for r in results if r['world'] == os.path.basename(world) and 'error' not in r]
        ok = [r for r in rs if r['found'] and not r['wrong']]
        within = [r for r in ok if r['travel'] <= 10.0]
        wrong = [r for r in rs if r.get('found') and r['wrong']]

        def mw(key, rows):
            v = sorted(r[key] for r in rows)
            return (v[len(v) // 2], v[-1]) if v else (float('nan'), float('nan'))
        say('%s: %d runs: found correctly within 10 m %d (%.0f %%), wrong %d, not found %d; error after '
              'relocalization median / worst %.3f / %.3f m (at the instant %.3f / %.3f m); travel %.1f / %.1f m; '
              'search time %.3f / %.3f s; dead reckoning %.2f / %.2f m'
              % (name, len(rs), len(within), 100.0 * len(within) / max(1, len(rs)), len(wrong),
                 len([r for r in rs if not r['found']]), *mw('error_median', ok), *mw('error_found', ok),
                 *mw('travel', ok), *mw('search_seconds', ok), *mw('dead_reckoning', rs)))
        placed = [r for r in rs if r.get('found') and 'error_local' in r]
        if placed:
            say('%s: where found, the saved trees around were themselves %.2f / %.2f m off (median / worst); the pose '
                'error less that offset (against the trees around) %.3f / %.3f m; %d of %d within 1 m of them'
                % (name, *mw('map_offset', placed), *mw('error_local', placed),
                   len([r for r in placed if r['error_local'] <= args.wrong]), len(placed)))
        found = [r for r in rs if r.get('found')]
        if args.jump:
            back = [r for r in found if 'error_recovered' in r]
            say('%s: odometry jump of (%.1f m, %.1f m, %.0f deg) after %.0f m: %d of %d runs found again (the '
                  'particles moved), error over the 5 s after median / worst %.3f / %.3f m, under 0.3 m in %d; final '
                  'error median / worst %.3f / %.3f m (the drive may leave the stand)'
                  % (name, args.jump[0], args.jump[1], args.jump[2], args.jump[3], len(back), len(found),
                     *mw('error_recovered', back), len([r for r in back if r['error_recovered'] < 0.3]),
                     *mw('error_final', found)))
        tot = {k: sum(r[k] for r in found) for k in ('felled_found', 'felled_eligible', 'felled_true',
                                                      'felled_reported', 'new_found', 'new_eligible', 'new_true',
                                                      'new_reported', 'new_unmapped', 'changed_reported',
                                                      'new_found_any', 'new_eligible_any', 'felled_found_any',
                                                      'felled_eligible_any')}

        def pct(a, b):
            return 100.0 * a / b if b else float('nan')
        say('%s: felled recall %.0f %% (%d / %d in clear view for 1 s; %d / %d within --scope of the path), '
            'precision %.0f %% (%d / %d); new recall %.0f %% (%d / %d in reach '
              'of both visits; %d / %d of those visit 2 passed), '
              'precision %.0f %% (%d / %d; %d more were trees visit 1 had not mapped); %d radii reported changed '
              '(every tree grew 0..%.3f m)'
              % (name, pct(tot['felled_found'], tot['felled_eligible']), tot['felled_found'], tot['felled_eligible'],
                 tot['felled_found_any'], tot['felled_eligible_any'], pct(tot['felled_true'], tot['felled_reported']), tot['felled_true'], tot['felled_reported'],
                 pct(tot['new_found'], tot['new_eligible']), tot['new_found'], tot['new_eligible'],
                 tot['new_found_any'], tot['new_eligible_any'],
                 pct(tot['new_true'], tot['new_reported']), tot['new_true'], tot['new_reported'],
                 tot['new_unmapped'], tot['changed_reported'], args.grow))
        pairs = [q for r in found for q in r.get('changed_pairs', [])]
        if pairs:
            diff = sorted(1000.0 * (a - b) for a, b in pairs)
            err = sorted(abs(d) for d in diff)
            true = sorted(1000.0 * b for _, b in pairs)
            say('%s: radius changes: %d reported (%d set beside their tree); reported minus true growth median %+.1f '
                'mm, its size median %.1f mm, at most %.1f mm; %d reported shrinking (no tree shrank); the true growth '
                'of the trees reported median %.1f mm (every tree grew 0..%.0f mm)'
                % (name, tot['changed_reported'], len(pairs), diff[len(diff) // 2], err[len(err) // 2], err[-1],
                   len([a for a, _ in pairs if a < 0.0]), true[len(true) // 2], 1000.0 * args.grow))
        if args.gps:
            for key, what in (('anchor1', 'visit 1 (fitted)'), ('anchor2', 'after visit 2 (combined)')):
                have = [r[key] for r in rs if r.get(key)]
                v = sorted(a['trees_median'] for a in have)
                within = len([x for x in v if x <= 1.0])
                say('%s: anchor %s: %d of %d runs anchored; trees placed median / worst %.2f / %.2f m off; '
                      '%d within 1 m' % (name, what, len(have), len(rs), v[len(v) // 2] if v else float('nan'),
                                         v[-1] if v else float('nan'), within))
        sys.stdout.flush()
    if args.report:
        write_report(args.report, args, results, summary, argv)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        tmp = os.path.join(args.out, '.lifelong.json.tmp')
        with open(tmp, 'w') as f:
            json.dump(results, f, indent=1)
        os.replace(tmp, os.path.join(args.out, 'lifelong.json'))
    return 0
