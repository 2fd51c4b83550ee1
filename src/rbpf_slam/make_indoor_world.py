"""Writes the indoor world of the 2D-lidar simulator: OUT_DIR/indoor.pgm and OUT_DIR/indoor.yaml.

An office-like floor of 24 m x 16 m at 0.05 m/cell in the ROS map_server layout (P5 image as map_saver
writes it: 0 occupied, 254 free, 205 unknown). A corridor loop 2.4 m wide runs around a central block of
three rooms; a row of rooms to the north and one to the east open on it through 1.2 m doors; pillars along
the corridor walls and furniture in the rooms give a scan matcher something to hold on to in the long
corridors, and differ from side to side so that the loop is not symmetric. Outer walls are 0.2 m, corridor
walls 0.15 m, room partitions 0.1 m thick. Everything outside the building is unknown.

The origin is chosen so that the start pose of the loop is the world origin. The YAML names the start pose
and the waypoints of the loop (world x y) in comment lines that parse as YAML once the leading '# ' is
dropped; the script checks that they keep at least 0.8 m from every occupied cell before writing anything.

Deterministic: the same files on every run. Pure Python 3 (3.8 or later), no third-party modules (the
package's own atomic writer, src/rbpf_slam/atomic.py, writes the files).
Usage: rosrun rbpf_slam make_indoor_world OUT_DIR      (the package ships its output in config/worlds)
"""
import math
import os
import sys

from rbpf_slam import atomic  # the package's one atomic writer

RESOLUTION = 0.05  # [m/cell]
MARGIN = 1.0  # [m] unknown border around the building
BUILDING_W = 24.0  # [m]
BUILDING_H = 16.0  # [m]

FREE, OCCUPIED, UNKNOWN = 254, 0, 205  # pixel values as map_saver writes them

OUTER_WALL = 0.2
CORRIDOR_WALL = 0.15
PARTITION = 0.1

# The corridor loop's centre line in building coordinates (building lower-left outer corner = (0, 0)).
LOOP_X0, LOOP_X1 = 1.4, 16.9
LOOP_Y0, LOOP_Y1 = 1.4, 10.9
START_BUILDING = (4.0, 1.4)  # in the south corridor; the robot heads east (+x) along the loop
START_YAW = 0.0
MIN_CLEARANCE = 0.8  # [m] required between the loop (waypoints and the segments between them) and any wall

# Walls and furniture as rectangles (x0, y0, x1, y1) in building coordinates [m].
WALLS = [
    # outer walls
    (0.0, 0.0, BUILDING_W, OUTER_WALL),
    (0.0, BUILDING_H - OUTER_WALL, BUILDING_W, BUILDING_H),
    (0.0, 0.0, OUTER_WALL, BUILDING_H),
    (BUILDING_W - OUTER_WALL, 0.0, BUILDING_W, BUILDING_H),
    # central block [2.6, 15.7] x [2.6, 9.7], inside the loop
    (2.6, 2.6, 15.7, 2.75),
    (2.6, 9.55, 15.7, 9.7),
    (2.6, 2.6, 2.75, 9.7),
    (15.55, 2.6, 15.7, 9.7),
    # its partitions into rooms A (west), B (middle), C (east)
    (7.0, 2.75, 7.1, 9.55),
    (11.5, 2.75, 11.6, 9.55),
    # corridor walls on the far side of the loop: the north rooms' wall and the east rooms' wall
    (OUTER_WALL, 12.1, 18.25, 12.25),
    (18.1, OUTER_WALL, 18.25, BUILDING_H - OUTER_WALL),
    # partitions of the north rooms N1, N2, N3 and the east rooms E1, E2, E3
    (6.0, 12.25, 6.1, BUILDING_H - OUTER_WALL),
    (12.0, 12.25, 12.1, BUILDING_H - OUTER_WALL),
    (18.25, 5.0, BUILDING_W - OUTER_WALL, 5.1),
    (18.25, 10.0, BUILDING_W - OUTER_WALL, 10.1),
]

# Door gaps (>= 1 m) cut out of the walls above, as rectangles through the wall's thickness.
DOORS = [
    (4.5, 2.6, 5.7, 2.75),  # A, from the south corridor
    (2.6, 5.5, 2.75, 6.7),  # A, from the west corridor
    (7.0, 7.6, 7.1, 8.6),  # A <-> B
    (8.8, 9.55, 10.0, 9.7),  # B, from the north corridor
    (12.8, 2.6, 14.0, 2.75),  # C, from the south corridor
    (3.0, 12.1, 4.2, 12.25),  # N1
    (10.2, 12.1, 11.4, 12.25),  # N2
    (14.0, 12.1, 15.2, 12.25),  # N3
    (18.1, 2.8, 18.25, 4.0),  # E1
    (18.1, 7.0, 18.25, 8.2),  # E2
    (18.1, 10.6, 18.25, 11.8),  # E3
]

# Pillars (0.4 m wide, 0.25 m deep, against the corridor walls) and furniture blocks in the rooms.
BLOCKS = [
    # south corridor, against the outer wall
    (6.0, 0.2, 6.4, 0.45),
    (10.5, 0.2, 10.9, 0.45),
    (14.0, 0.2, 14.4, 0.45),
    # west corridor, against the outer wall
    (0.2, 4.0, 0.45, 4.4),
    (0.2, 8.0, 0.45, 8.4),
    # east corridor, against the east rooms' wall
    (17.85, 5.8, 18.1, 6.2),
    # north corridor, against the central block
    (4.0, 9.7, 4.4, 9.95),
    (13.0, 9.7, 13.4, 9.95),
    # room A: table, cabinet
    (4.0, 4.0, 6.0, 5.0),
    (2.75, 8.0, 3.35, 9.55),
    # room B: two desks, a shelf
    (7.8, 3.4, 9.4, 4.2),
    (9.8, 5.5, 11.0, 6.3),
    (11.0, 3.0, 11.5, 4.5),
    # room C: two rows of racks
    (12.5, 5.0, 14.5, 5.6),
    (12.5, 6.6, 14.5, 7.2),
    # north rooms
    (1.0, 14.2, 2.6, 15.0),
    (7.5, 13.6, 10.5, 14.6),
    (16.5, 13.0, 18.1, 13.6),
    # east rooms
    (21.0, 1.5, 22.5, 3.0),
    (20.0, 6.5, 21.6, 7.3),
    (22.0, 8.5, 23.8, 9.3),
    (20.5, 12.0, 22.0, 13.5),
]

# The loop, counter-clockwise from the start, closing at the start [building coordinates].
LOOP_BUILDING = [
    START_BUILDING,
    (8.0, LOOP_Y0),
    (12.0, LOOP_Y0),
    (LOOP_X1, LOOP_Y0),
    (LOOP_X1, 6.0),
    (LOOP_X1, LOOP_Y1),
    (12.0, LOOP_Y1),
    (7.0, LOOP_Y1),
    (LOOP_X0, LOOP_Y1),
    (LOOP_X0, 6.0),
    (LOOP_X0, LOOP_Y0),
    START_BUILDING,
]


def cells(v):
    """Metres to a whole number of cells (every coordinate above is a multiple of the resolution)."""
    n = round(v / RESOLUTION)
    if abs(n * RESOLUTION - v) > 1e-9:
        raise ValueError('%g m is not a multiple of the resolution' % v)
    return n


class Canvas(object):
    """Grid of pixel values, row 0 at the bottom (world convention); flipped when written."""

    def __init__(self):
        self.width = cells(BUILDING_W + 2 * MARGIN)
        self.height = cells(BUILDING_H + 2 * MARGIN)
        self.offset = cells(MARGIN)
        self.data = bytearray([UNKNOWN]) * (self.width * self.height)

    def fill(self, rect, value):
        x0, y0, x1, y1 = rect
        c0, c1 = cells(x0) + self.offset, cells(x1) + self.offset
        r0, r1 = cells(y0) + self.offset, cells(y1) + self.offset
        for row in range(r0, r1):
            start = row * self.width
            self.data[start + c0:start + c1] = bytes([value]) * (c1 - c0)

    def occupied_cells(self):
        return [(i % self.width, i // self.width) for i, v in enumerate(self.data) if v == OCCUPIED]

    def pgm(self):
        header = 'P5\n# CREATOR: make_indoor_world.py %.3f m/pix\n%d %d\n255\n' % (RESOLUTION, self.width,
                                                                                      self.height)
        rows = [bytes(self.data[r * self.width:(r + 1) * self.width]) for r in range(self.height - 1, -1, -1)]
        return header.encode('ascii') + b''.join(rows)


def build():
    canvas = Canvas()
    canvas.fill((0.0, 0.0, BUILDING_W, BUILDING_H), FREE)
    for rect in WALLS + BLOCKS:
        canvas.fill(rect, OCCUPIED)
    for rect in DOORS:
        canvas.fill(rect, FREE)
    return canvas


def to_world(bx, by):
    """Building coordinates to world coordinates: the start point is the world origin."""
    return (round(bx - START_BUILDING[0], 6), round(by - START_BUILDING[1], 6))


def origin():
    """World pose of the image's lower-left corner (map_server's origin)."""
    x, y = to_world(-MARGIN, -MARGIN)
    return (x, y, 0.0)


def clearance(canvas, occupied_index, bx, by, radius):
    """Distance [m] from building point (bx, by) to the nearest occupied cell, capped at ``radius``."""
    px = (bx + MARGIN) / RESOLUTION
    py = (by + MARGIN) / RESOLUTION
    reach = int(math.ceil(radius / RESOLUTION)) + 1
    best = radius
    for col in range(int(px) - reach, int(px) + reach + 1):
        for row in occupied_index.get(col, ()):
            if abs(row - py) > reach:
                continue
            dx = max(col - px, 0.0, px - (col + 1))
            dy = max(row - py, 0.0, py - (row + 1))
            best = min(best, math.hypot(dx, dy) * RESOLUTION)
    return best


def check(canvas):
    """Raises if the loop is not clear; returns (minimum clearance [m], loop length [m])."""
    index = {}
    for col, row in canvas.occupied_cells():
        index.setdefault(col, []).append(row)
    cap = 2.0
    worst = cap
    length = 0.0
    for (ax, ay), (bx, by) in zip(LOOP_BUILDING[:-1], LOOP_BUILDING[1:]):
        seg = math.hypot(bx - ax, by - ay)
        length += seg
        steps = max(1, int(math.ceil(seg / RESOLUTION)))
        for k in range(steps + 1):
            s = float(k) / steps
            x, y = ax + s * (bx - ax), ay + s * (by - ay)
            c = clearance(canvas, index, x, y, cap)
            if c < MIN_CLEARANCE:
                raise RuntimeError('loop point (%.2f, %.2f) [world] is only %.2f m from a wall'
                                   % (to_world(x, y) + (c,)))
            worst = min(worst, c)
    if LOOP_BUILDING[0] != LOOP_BUILDING[-1]:
        raise RuntimeError('the loop does not close')
    return worst, length


def fmt(v):
    text = '%.6f' % v
    text = text.rstrip('0')
    return text + '0' if text.endswith('.') else text


def yaml_text(min_clearance, length):
    sx, sy = to_world(*START_BUILDING)
    waypoints = ', '.join('[%s, %s]' % tuple(fmt(c) for c in to_world(x, y)) for x, y in LOOP_BUILDING)
    ox, oy, oyaw = origin()
    lines = [
        '# Indoor world of the 2D-lidar simulator: an office floor of %g m x %g m at %g m/cell (map_server layout).'
        % (BUILDING_W, BUILDING_H, RESOLUTION),
        '# Generated by make_indoor_world: edit the generator and run it again, not this file.',
        '# A 2.4 m corridor loop around a central block of three rooms; rooms to the north and east behind',
        '# 1.2 m doors; pillars along the corridors; furniture in the rooms; unknown outside the building.',
        '# The start pose is free and is the world origin (x, y [m], yaw [rad]; heading east along the south',
        '# corridor). The loop waypoints (world x y [m]) run counter-clockwise through the corridors, %.1f m,'
        % length,
        '# back to the start; the loop keeps >= %.2f m from every wall. Drop "# " to parse these as YAML:'
        % min_clearance,
        '# start_pose: [%s, %s, %s]' % (fmt(sx), fmt(sy), fmt(START_YAW)),
        '# loop_waypoints: [%s]' % waypoints,
        'image: indoor.pgm',
        'resolution: %s' % fmt(RESOLUTION),
        'origin: [%s, %s, %s]' % (fmt(ox), fmt(oy), fmt(oyaw)),
        'negate: 0',
        'occupied_thresh: 0.65',
        'free_thresh: 0.196',
        'mode: trinary',
    ]
    return '\n'.join(lines) + '\n'


def main(argv=None):
    """The command (@p argv: its arguments, default sys.argv[1:]): exit code 0; 2 for a usage error."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if len(argv) != 1:
        sys.stderr.write('usage: python3 %s OUT_DIR\n' % sys.argv[0])
        return 2
    out_dir = argv[0]
    if not os.path.isdir(out_dir):
        os.makedirs(out_dir)
    canvas = build()
    min_clearance, length = check(canvas)
    atomic.write_bytes(os.path.join(out_dir, 'indoor.pgm'), canvas.pgm())
    atomic.write_bytes(os.path.join(out_dir, 'indoor.yaml'), yaml_text(min_clearance, length).encode('ascii'))
    print('wrote %s/indoor.{pgm,yaml}: %d x %d cells, loop %.1f m, clearance >= %.2f m'
          % (out_dir, canvas.width, canvas.height, length, min_clearance))
    return 0
