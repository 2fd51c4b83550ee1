"""Soak benchmark: replays a bag through the SLAM nodes, looped, at full speed, for hours of sensor time, and
samples the nodes' memory (resident set size) every second.

A looped bag jumps back in time at every loop, so the filter restarts each time (as it must): the run then also
checks that restarts give their memory back. Memory is reported as the largest resident size after the first
minute against the one at the first minute; flat means within 5 %.

  soak_benchmark --filter grid --bag intel.bag --hours 1 --rate 20
  soak_benchmark --filter fastslam --bag forest.bag --hours 1 --rate 4
  soak_benchmark --filter fastslam --trunk-drive loop --hours 1 --rate 4     # one drive, no restarts
  soak_benchmark --filter fastslam --trunk-drive survey --hours 1 --rate 4   # one drive over new ground
  soak_benchmark --filter fastslam --trunk-drive loop --hours 1 --rate 4 --save-map-every 60  # saving the map

--trunk-drive writes (to a temporary folder) and plays once a drive of --hours without a jump in time: odometry
and the trunks a sensor of 1-12 m all round sees (rbpf_slam/TrunkArray), either round the same 40 m loop again and
again (the map stops growing: memory must be flat) or across a stand in parallel lanes (the map grows: the
figure is MB per 1000 landmarks, from the node's inventory at the first minute and at the end).

Needs a sourced workspace (rosrun). Prints a table and writes --out FILE.json (atomically) when given.
"""
import argparse
import math
import os
import signal
import subprocess
import time

from rbpf_slam.atomic import UserError, run_tool, write_json
from rbpf_slam import paths



def rss_mb(pid):
    """Resident set size [MB] of process pid, None once it is gone."""
    try:
        with open('/proc/%d/status' % pid) as f:
            for line in f:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def bag_duration(bag):
    import rosbag
    with rosbag.Bag(bag) as b:
        return b.get_end_time() - b.get_start_time()


def start(args, env, log):
    return subprocess.Popen(args, env=env, stdout=log, stderr=subprocess.STDOUT, preexec_fn=os.setsid)


def stop(proc):
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def write_trunk_drive(path, kind, hours, seed=1):
    """A drive without jumps in time: odometry at 20 Hz (0.5 % scale and 1 deg/min heading drift), TrunkArrays at
    10 Hz of the trees within 1-12 m of the true pose (2 cm noise), /tf_static base_link -> lidar. Returns the number
    of trees of the stand."""
    import random
    import rosbag
    from rbpf_slam import convert_msgs as cm
    from tqdm import tqdm
    rng = random.Random(seed)
    speed, dt = 1.0, 0.05
    steps = int(hours * 3600.0 / dt)
    if kind == 'loop':
        extent = (-15.0, 55.0, -15.0, 25.0)
    else:  # lanes 20 m apart across a stand as long as the drive needs
        lanes = 8
        length = steps * dt * speed / lanes
        extent = (-15.0, length + 15.0, -15.0, 20.0 * lanes + 15.0)
    area = (extent[1] - extent[0]) * (extent[3] - extent[2])
    trees = []
    for _ in range(int(area * 0.02)):  # 200 stems/ha
        x, y = rng.uniform(extent[0], extent[1]), rng.uniform(extent[2], extent[3])
        trees.append((x, y, rng.uniform(0.1, 0.3)))
    cell = 12.0
    grid = {}
    for t in trees:
        grid.setdefault((int(math.floor(t[0] / cell)), int(math.floor(t[1] / cell))), []).append(t)

    def truth(k):
        s_ = k * dt * speed
        if kind == 'loop':  # a 40 m x 10 m rectangle, driven round and round
            s_ %= 100.0
            for (x0, y0, x1, y1) in ((0, 0, 40, 0), (40, 0, 40, 10), (40, 10, 0, 10), (0, 10, 0, 0)):
                seg = math.hypot(x1 - x0, y1 - y0)
                if s_ <= seg:
                    return x0 + (x1 - x0) * s_ / seg, y0 + (y1 - y0) * s_ / seg, math.atan2(y1 - y0, x1 - x0)
                s_ -= seg
            return 0.0, 0.0, 0.0
        lane = int(s_ // length)
        along = s_ - lane * length
        x = along if lane % 2 == 0 else length - along
        return x, 20.0 * lane, 0.0 if lane % 2 == 0 else math.pi
    t0 = 1000.0
    odo = [0.0, 0.0, 0.0]
    prev = truth(0)
    with rosbag.Bag(path + '.tmp', 'w') as bag:
        bag.write('/tf_static', cm.tf_message(cm.transform(t0, 'base_link', 'lidar', 0.0, 0.0, 0.0, 1.0)),
                  cm.ros_time(t0))
        for k in tqdm(range(steps), desc='trunk drive', unit='step', mininterval=2.0):
            t = t0 + k * dt
            stamp = cm.ros_time(t)
            x, y, yaw = truth(k)
            dx, dy = x - prev[0], y - prev[1]
            c, s_ = math.cos(prev[2]), math.sin(prev[2])
            fwd, side = c * dx + s_ * dy, -s_ * dx + c * dy
            dyaw = math.atan2(math.sin(yaw - prev[2]), math.cos(yaw - prev[2]))
            fwd *= 1.005
            dyaw += math.radians(1.0) / 60.0 * dt
            odo[0] += math.cos(odo[2]) * fwd - math.sin(odo[2]) * side
            odo[1] += math.sin(odo[2]) * fwd + math.cos(odo[2]) * side
            odo[2] += dyaw
            prev = (x, y, yaw)
            bag.write('/odom', cm.odometry(t, 'odom', 'base_link', odo[0], odo[1], odo[2]), stamp)
            if k % 2:
                continue
            seen = []
            cx, cy = int(math.floor(x / cell)), int(math.floor(y / cell))
            c, s_ = math.cos(yaw), math.sin(yaw)
            for gx in (cx - 1, cx, cx + 1):
                for gy in (cy - 1, cy, cy + 1):
                    for (tx, ty, r) in grid.get((gx, gy), ()):
                        lx, ly = c * (tx - x) + s_ * (ty - y), -s_ * (tx - x) + c * (ty - y)
                        if 1.0 <= math.hypot(lx, ly) <= 12.0:
                            seen.append(cm.trunk(lx + rng.gauss(0.0, 0.02), ly + rng.gauss(0.0, 0.02), r, 1e-4,
                                                 (4e-4, 0.0, 0.0, 4e-4)))
            bag.write('/trunks', cm.trunk_array(t, 'lidar', seen, {'min_range': 1.0, 'max_range': 12.0}), stamp)
    os.replace(path + '.tmp', path)
    return len(trees)


def inventory_trees(env, path):
    """Asks the FastSLAM node for its inventory (~save_inventory) and counts the trees in it (None: no answer)."""
    r = subprocess.run(['rosservice', 'call', '/fastslam/save_inventory'], env=env, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, timeout=60)
    if r.returncode != 0 or not os.path.isfile(path):
        return None
    with open(path) as f:
        return max(0, len([l for l in f if l.strip() and not l.startswith('#')]) - 1)


def nodes_for(opts):
    """The processes to start (name, command) for the filter; each loads its nodelets in-process."""
    if opts.filter == 'grid':
        params = ['_%s:=%s' % kv for kv in (('particles', opts.particles),) if kv[1]]
        return [('grid_slam', ['rosrun', 'rbpf_slam', 'grid_slam', '__name:=grid_slam'] + params)]
    # FastSLAM: the extraction and the filter as two nodes (each a nodelet loaded in its own process).
    return [('trunk_extraction', ['rosrun', 'rbpf_slam', 'trunk_extraction', '__name:=trunk_extraction']),
            ('fastslam', ['rosrun', 'rbpf_slam', 'fastslam', '__name:=fastslam'] +
             (['_particles:=%d' % opts.particles] if opts.particles else []))]


def param_files(opts):
    """The (node namespace, YAML file) pairs to load, in order: the filter's advanced file first, the user's file on
    top (as the launch files load them), then --config."""
    cfg = paths.package_file('config')
    files = {'grid': [('grid_slam', os.path.join(cfg, 'grid_slam_advanced.yaml')),
                      ('grid_slam', os.path.join(cfg, 'grid_slam.yaml'))],
             'fastslam': [('trunk_extraction', os.path.join(cfg, 'trunk_extraction.yaml')),
                          ('fastslam', os.path.join(cfg, 'fastslam_advanced.yaml')),
                          ('fastslam', os.path.join(cfg, 'fastslam.yaml'))]}[opts.filter]
    if opts.config:
        files.append((files[-1][0], opts.config))
    return files


def load_params(opts, env):
    for ns, path in param_files(opts):
        subprocess.run(['rosparam', 'load', path, '/' + ns], env=env, check=True)
    subprocess.run(['rosparam', 'set', '/use_sim_time', 'true'], env=env, check=True)


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr for a bad input or a failed run."""
    return run_tool('soak_benchmark', _main, argv)


def _main(argv):
    p = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    p.add_argument('--filter', choices=('grid', 'fastslam'), required=True)
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument('--bag', help='a bag with the sensor topics, odometry and /tf, /tf_static (played looped)')
    src.add_argument('--trunk-drive', choices=('loop', 'survey'),
                     help='FastSLAM: write and play once a drive of --hours without a jump in time (see above)')
    p.add_argument('--config', help='a YAML laid over the filter\'s shipped ones (e.g. config/grid_single_map.yaml)')
    p.add_argument('--particles', type=int, default=0)
    p.add_argument('--hours', type=float, default=1.0, help='sensor time to replay [h] (default 1)')
    p.add_argument('--rate', type=float, default=20.0, help='rosbag play rate (default 20)')
    p.add_argument('--port', type=int, default=11391, help='port of the roscore it starts (default 11391)')
    p.add_argument('--out', help='write the figures and the samples as JSON')
    p.add_argument('--save-map-every', type=float, default=0.0, metavar='S',
                   help='FastSLAM: call ~save_map every S seconds of sensor time (0: never), to see that saving '
                        'gives back what it takes')
    opts = p.parse_args(argv)
    if opts.save_map_every < 0.0 or (opts.save_map_every > 0.0 and opts.filter != 'fastslam'):
        raise UserError('--save-map-every must be >= 0 and goes with --filter fastslam')
    logdir = os.path.join('/tmp', 'rbpf_slam_soak_%d' % os.getpid())
    os.makedirs(logdir, exist_ok=True)
    stand = None
    if opts.trunk_drive:
        if opts.filter != 'fastslam':
            raise UserError('--trunk-drive goes with --filter fastslam')
        opts.bag = os.path.join(logdir, 'trunk_drive_%s.bag' % opts.trunk_drive)
        stand = write_trunk_drive(opts.bag, opts.trunk_drive, opts.hours)
    if not os.path.isfile(opts.bag):
        raise UserError('%s: no such bag' % opts.bag)
    duration = bag_duration(opts.bag)
    if duration <= 0.0:
        raise UserError('%s: the bag spans no time' % opts.bag)
    loops = 1 if opts.trunk_drive else max(1, int(-(-opts.hours * 3600.0 // duration)))
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % opts.port, ROS_HOSTNAME='localhost')
    inventory = os.path.join(logdir, 'inventory.csv')
    logs, procs = [], []
    try:
        log = open(os.path.join(logdir, 'roscore.log'), 'w')
        logs.append(log)
        core = start(['roscore', '-p', str(opts.port)], env, log)
        procs.append(core)
        deadline = time.time() + 30
        while subprocess.run(['rosparam', 'list'], env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.DEVNULL).returncode != 0:
            if time.time() > deadline:
                raise UserError('roscore did not start on port %d (log: %s)' % (opts.port, log.name))
            time.sleep(0.5)
        load_params(opts, env)
        if opts.filter == 'fastslam':  # its files (the inventory, the maps before each restart) in the log folder
            subprocess.run(['rosparam', 'set', '/fastslam/inventory_path', inventory], env=env, check=True)
            subprocess.run(['rosparam', 'set', '/fastslam/map_path', os.path.join(logdir, 'forest_map.csv')], env=env,
                           check=True)
        else:
            subprocess.run(['rosparam', 'set', '/grid_slam/map_path', os.path.join(logdir, 'map.yaml')], env=env,
                           check=True)
        nodes = []
        for name, cmd in nodes_for(opts):  # rosrun execs the node: its pid is the node's
            log = open(os.path.join(logdir, name + '.log'), 'w')
            logs.append(log)
            proc = start(cmd, env, log)
            procs.append(proc)
            nodes.append((name, proc))
        time.sleep(3.0)
        log = open(os.path.join(logdir, 'play.log'), 'w')
        logs.append(log)
        play_cmd = ['rosbag', 'play', '--clock', '-q', '-r', str(opts.rate)] + ([] if opts.trunk_drive else ['-l']) + \
            [opts.bag]
        play = start(play_cmd, env, log)
        procs.append(play)
        wall = loops * duration / opts.rate
        print('soak_benchmark: %s, %d loops of %s (%.0f s each) = %.2f h of sensor time at %gx: ~%.0f s; logs %s'
              % (opts.filter, loops, os.path.basename(opts.bag), duration, loops * duration / 3600.0, opts.rate,
                 wall, logdir))
        samples = []
        trees_at_minute = None
        saves, saving = 0, None
        t0 = time.time()
        while time.time() - t0 < wall:
            time.sleep(1.0)
            if opts.save_map_every > 0.0 and (time.time() - t0) * opts.rate >= (saves + 1) * opts.save_map_every:
                if saving is None or saving.poll() is not None:  # one call at a time
                    saving = subprocess.Popen(['rosservice', 'call', '/fastslam/save_map'], env=env,
                                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    saves += 1
            if opts.filter == 'fastslam' and trees_at_minute is None and time.time() - t0 >= 60.0:
                trees_at_minute = inventory_trees(env, inventory)
            row = {'t': round(time.time() - t0, 1)}
            for name, proc in nodes:
                row[name] = rss_mb(proc.pid) if proc.poll() is None else None
                if row[name] is None:
                    raise UserError('%s died after %.0f s (log: %s)' % (name, row['t'],
                                                                         os.path.join(logdir, name + '.log')))
            samples.append(row)
            if len(samples) % 60 == 0:
                print('  %5.0f s: ' % row['t'] + ', '.join('%s %.1f MB' % (n, row[n] if row[n] else 0)
                                                          for n, _ in nodes), flush=True)
        figures = {}
        for name, _ in nodes:
            series = [(s['t'], s[name]) for s in samples if s.get(name)]
            first_minute = [v for t, v in series if t <= 60.0]
            after = [v for t, v in series if t > 60.0]
            if not first_minute or not after:
                raise UserError('the run was too short to judge (under a minute)')
            at_minute = first_minute[-1]
            figures[name] = {'rss_at_1_min_mb': at_minute, 'rss_max_after_mb': max(after),
                             'rss_final_mb': after[-1], 'growth_percent': 100.0 * (max(after) - at_minute) / at_minute}
        trees_final = inventory_trees(env, inventory) if opts.filter == 'fastslam' else None
        resets = 0
        for name, _ in nodes:
            with open(os.path.join(logdir, name + '.log')) as f:
                resets += f.read().count('time jumped back')
        print('| node | RSS at 1 min | max after | final | growth |')
        print('|---|---|---|---|---|')
        for name, f in figures.items():
            print('| %s | %.1f MB | %.1f MB | %.1f MB | %+.1f %% |' % (name, f['rss_at_1_min_mb'], f['rss_max_after_mb'],
                                                               f['rss_final_mb'], f['growth_percent']))
        print('restarts logged (time jumped back): %d; sensor time %.2f h in %.0f s'
              % (resets, loops * duration / 3600.0, time.time() - t0))
        if opts.save_map_every > 0.0:
            print('save_map called %d times (every %g s of sensor time)' % (saves, opts.save_map_every))
        per_1000 = None
        if trees_at_minute is not None and trees_final is not None:
            f = figures['fastslam']
            grown = trees_final - trees_at_minute
            # per 1000 landmarks only where the map grew by hundreds (a few landmarks more say nothing)
            per_1000 = 1000.0 * (f['rss_final_mb'] - f['rss_at_1_min_mb']) / grown if grown >= 200 else None
            print('landmarks in the best map: %d at 1 min, %d at the end%s%s'
                  % (trees_at_minute, trees_final, '' if stand is None else ' (%d trees in the stand)' % stand,
                     '' if per_1000 is None else '; %.2f MB per 1000 landmarks' % per_1000))
        if opts.out:
            write_json(opts.out, {'filter': opts.filter, 'bag': os.path.basename(opts.bag), 'loops': loops,
                                  'rate': opts.rate, 'hours': loops * duration / 3600.0, 'restarts': resets,
                                  'landmarks_at_1_min': trees_at_minute, 'landmarks_final': trees_final,
                                  'mb_per_1000_landmarks': per_1000,
                                  'figures': figures, 'samples': samples})
        return 0
    finally:
        for proc in reversed(procs):
            stop(proc)
        for log in logs:
            log.close()
