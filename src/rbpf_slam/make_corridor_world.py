"""Writes a long-corridor world for the 2D-lidar simulator: OUT_DIR/corridor.pgm, OUT_DIR/corridor.yaml and
OUT_DIR/corridor_loop.txt (the drive's waypoints).

Two straight corridors LENGTH m long and 3 m wide, WIDTH m apart, joined at both ends by cross corridors: a
loop of about 2 * (LENGTH + WIDTH) m. The long corridors have plain walls with doors set back 0.3 m into them
at irregular spacing (8-20 m, drawn from a fixed seed) and nothing else: a structure that a scan matcher
slides along, since most of a scan sees two parallel walls. The robot starts in the south corridor heading
east, drives the loop counter-clockwise and ends a few metres past its start, so the loop can close.

The start pose is the world origin. Deterministic: the same files on every run. Python 3.8+, no third-party
modules.
Usage: rosrun rbpf_slam make_corridor_world OUT_DIR [--length M] [--width M]
"""
import argparse
import os
import random

from rbpf_slam import atomic  # the package's one atomic writer

RESOLUTION = 0.1  # [m/cell]
MARGIN = 2.0  # [m] unknown border
WALL = 0.2  # [m]
HALF = 1.5  # [m] half a corridor's width
DOOR = 1.2  # [m] door width
RECESS = 0.3  # [m] how far a door is set back into the wall
FREE, OCCUPIED, UNKNOWN = 254, 0, 205


class Canvas(object):
    """Pixel grid over world coordinates [x0, x1] x [y0, y1], row 0 at the bottom."""

    def __init__(self, x0, y0, x1, y1):
        self.x0, self.y0 = x0, y0
        self.width = int(round((x1 - x0) / RESOLUTION))
        self.height = int(round((y1 - y0) / RESOLUTION))
        self.data = bytearray([UNKNOWN]) * (self.width * self.height)

    def fill(self, rect, value):
        x0, y0, x1, y1 = rect
        c0 = max(0, int(round((x0 - self.x0) / RESOLUTION)))
        c1 = min(self.width, int(round((x1 - self.x0) / RESOLUTION)))
        r0 = max(0, int(round((y0 - self.y0) / RESOLUTION)))
        r1 = min(self.height, int(round((y1 - self.y0) / RESOLUTION)))
        for row in range(r0, r1):
            start = row * self.width
            self.data[start + c0:start + c1] = bytes([value]) * (c1 - c0)

    def pgm(self):
        rows = [bytes(self.data[r * self.width:(r + 1) * self.width]) for r in range(self.height - 1, -1, -1)]
        header = 'P5\n# CREATOR: make_corridor_world.py %.3f m/pix\n%d %d\n255\n' % (RESOLUTION, self.width,
                                                                                  self.height)
        return header.encode('ascii') + b''.join(rows)


def corridor(canvas, x0, y0, x1, y1):
    """A corridor's free space [x0, x1] x [y0, y1] with walls around it (drawn before the free space)."""
    canvas.fill((x0 - WALL, y0 - WALL, x1 + WALL, y1 + WALL), OCCUPIED)


def build(length, width):
    x_end = length
    canvas = Canvas(-HALF - WALL - MARGIN, -HALF - WALL - MARGIN, x_end + HALF + WALL + MARGIN,
                    width + HALF + WALL + MARGIN)
    spans = [(-HALF, -HALF, x_end + HALF, HALF), (-HALF, width - HALF, x_end + HALF, width + HALF),
             (-HALF, -HALF, HALF, width + HALF), (x_end - HALF, -HALF, x_end + HALF, width + HALF)]
    for s in spans:
        corridor(canvas, *s)
    for s in spans:
        canvas.fill(s, FREE)
    rng = random.Random(7)
    for y_wall, side in ((-HALF, -1), (HALF, 1), (width - HALF, -1), (width + HALF, 1)):
        x = 6.0 + rng.uniform(0.0, 6.0)
        while x < x_end - 6.0:
            lo, hi = (y_wall - RECESS, y_wall) if side < 0 else (y_wall, y_wall + RECESS)
            canvas.fill((x, lo, x + DOOR, hi), FREE)
            x += rng.uniform(8.0, 20.0)
    return canvas


def main(argv=None):
    """The command (@p argv: its arguments, default sys.argv[1:]): exit code 0."""
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('out_dir')
    p.add_argument('--length', type=float, default=150.0, help='length of the long corridors [m] (default 150)')
    p.add_argument('--width', type=float, default=20.0, help='distance between them [m] (default 20)')
    args = p.parse_args(argv)
    if not os.path.isdir(args.out_dir):
        os.makedirs(args.out_dir)
    canvas = build(args.length, args.width)
    yaml = '\n'.join([
        '# Long-corridor world of the 2D-lidar simulator (make_corridor_world --length %g --width %g):'
        % (args.length, args.width),
        '# two %g m corridors %g m apart, joined at their ends; start pose = world origin, heading east.'
        % (args.length, args.width),
        'image: corridor.pgm',
        'resolution: %g' % RESOLUTION,
        'origin: [%g, %g, 0.0]' % (canvas.x0, canvas.y0),
        'negate: 0',
        'occupied_thresh: 0.65',
        'free_thresh: 0.196',
        'mode: trinary',
    ]) + '\n'
    loop = [(args.length, 0.0), (args.length, args.width), (0.0, args.width), (0.0, 0.0), (8.0, 0.0)]
    atomic.write_bytes(os.path.join(args.out_dir, 'corridor.pgm'), canvas.pgm())
    atomic.write_bytes(os.path.join(args.out_dir, 'corridor.yaml'), yaml.encode('ascii'))
    atomic.write_bytes(os.path.join(args.out_dir, 'corridor_loop.txt'),
                       ''.join('%g %g\n' % w for w in loop).encode('ascii'))
    print('wrote %s/corridor.{pgm,yaml} (%d x %d cells) and corridor_loop.txt (%.0f m)'
          % (args.out_dir, canvas.width, canvas.height, 2 * (args.length + args.width) + 8.0))
    return 0
