"""Plots a `slam_bag --filter grid --out DIR` run: the map (DIR/map.yaml + map.pgm) with the estimated path,
the raw odometry and, given --reference (a TUM file, e.g. from `trajectory_eval --write-reference`), the
reference path rigidly fitted onto the estimate (least squares over the positions, matched by stamp). With
--paths, it plots TUM paths only (e.g. wheel odometry with and without IMU fusion).

  rosrun rbpf_slam plot_grid_run DIR [--reference REF.tum] [--out DIR/map.png] [--title TEXT]
  rosrun rbpf_slam plot_grid_run --paths A.tum B.tum --labels "encoders" "encoders + gyro" --out paths.png
"""
import argparse
import os

import numpy as np

from rbpf_slam import atomic, evaluate as ev


def read_tum(path):
    """(t, xy) of a TUM file (the evaluator's reader); empty arrays for an empty file."""
    if os.path.exists(path) and os.path.getsize(path) == 0:
        return np.zeros(0), np.zeros((0, 2))
    t, xy, _ = ev.read_tum(path)
    return t, xy


def read_pgm(path):
    """A binary PGM (P5) as a uint8 array, top row first; '#' comments allowed."""
    with open(path, 'rb') as f:
        data = f.read()
    tokens, pos = [], 0
    while len(tokens) < 4:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b'#':
            pos = data.index(b'\n', pos) + 1
            continue
        end = pos
        while end < len(data) and not data[end:end + 1].isspace():
            end += 1
        tokens.append(data[pos:end])
        pos = end
    if tokens[0] != b'P5':
        raise ValueError('%s: not a binary PGM' % path)
    w, h = int(tokens[1]), int(tokens[2])
    return np.frombuffer(data[pos + 1:pos + 1 + w * h], dtype=np.uint8).reshape(h, w)


def read_map_yaml(path):
    """resolution, origin (x, y) and the image path of a map_server YAML (the keys saveMapImage writes)."""
    values = {}
    with open(path) as f:
        for line in f:
            if ':' in line and not line.lstrip().startswith('#'):
                k, v = line.split(':', 1)
                values[k.strip()] = v.strip()
    origin = [float(x) for x in values['origin'].strip('[]').split(',')]
    image = values['image'].strip('"\'')
    if not os.path.isabs(image):
        image = os.path.join(os.path.dirname(path), image)
    return float(values['resolution']), origin[:2], image


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr for a missing or malformed input; 2 for a usage
    error."""
    return atomic.run_tool('plot_grid_run', _main, argv, errors=(ValueError, KeyError))


def _main(argv):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('run', nargs='?', help='output folder of slam_bag --filter grid')
    p.add_argument('--reference', help='reference path (TUM), fitted onto the estimate for display')
    p.add_argument('--paths', nargs='+', help='TUM files to plot (paths only)')
    p.add_argument('--labels', nargs='+', help='labels of --paths')
    p.add_argument('--title', default='')
    p.add_argument('--out', help='PNG to write (default RUN/map.png or paths.png)')
    args = p.parse_args(argv)
    if not args.run and not args.paths:
        p.error('give a run folder or --paths')
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 8))
    if args.paths:
        labels = args.labels or [os.path.basename(x) for x in args.paths]
        if len(labels) != len(args.paths):
            p.error('--labels needs one label per path')
        for path, label in zip(args.paths, labels):
            _, xy = read_tum(path)
            ax.plot(xy[:, 0], xy[:, 1], lw=1.2, label=label)
            if len(xy):
                ax.plot(xy[-1, 0], xy[-1, 1], 'o', ms=4, color=ax.lines[-1].get_color())
        out = args.out or 'paths.png'
    else:
        yaml = os.path.join(args.run, 'map.yaml')
        if os.path.exists(yaml):
            res, origin, image = read_map_yaml(yaml)
            img = read_pgm(image)
            h, w = img.shape
            ax.imshow(img, cmap='gray', vmin=0, vmax=255, interpolation='nearest',
                      extent=(origin[0], origin[0] + w * res, origin[1], origin[1] + h * res))
        te, est = read_tum(os.path.join(args.run, 'estimate.tum'))
        to, odo = read_tum(os.path.join(args.run, 'odometry.tum'))
        ax.plot(odo[:, 0], odo[:, 1], color='tab:orange', lw=0.8, label='raw odometry')
        if args.reference:
            tr, ref = read_tum(args.reference)
            i, j = ev.match_by_stamp(te, tr, 1e-3)
            if len(i) >= 2:
                r, t = ev.fit_rigid_2d(ref[j], est[i])
                fitted = ref.dot(r.T) + t
                ax.plot(fitted[:, 0], fitted[:, 1], color='tab:green', lw=0.8, label='reference (fitted)')
        ax.plot(est[:, 0], est[:, 1], color='tab:blue', lw=0.8, label='estimate')
        out = args.out or os.path.join(args.run, 'map.png')
    ax.set_aspect('equal')
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.legend(loc='best', fontsize=8)
    if args.title:
        ax.set_title(args.title)
    fig.tight_layout()
    atomic.save_figure(fig, out, dpi=110)
    print('wrote %s' % out)
    return 0
