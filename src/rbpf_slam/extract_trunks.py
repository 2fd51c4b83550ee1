"""Finds the tree trunks in a point-cloud file and writes their positions and diameters at breast height (DBH).

  extract_trunks CLOUD [--sensor=X,Y,Z] [--out PREFIX] [--ground-height H]

CLOUD is a PCD file (ascii, binary or binary_compressed, fields x y z), a LAS file, or a LAZ file when the Python
module laspy with a LAZ backend is installed (pip install 'laspy[lazrs]'); metres, z up. A terrestrial or mobile
scan of a stand, or of one tree: stems are found by their vertical continuity (circles fitted to horizontal slices
from 0.5 to 3 m above the ground that line up into columns), so branches, shrubs and crowns are not taken for
trunks; stems from 6 cm to 1.2 m DBH.

Writes PREFIX_trunks.csv (x, y, dbh, dbh_sigma, points, z_min, z_max; metres: the stem's axis and diameter 1.3 m
above the ground, the diameter's standard error, the points on the stem's circles and their height span) and
PREFIX_trunks.png (top view: the points' density, each trunk as a circle with its row number in the CSV and its
DBH). PREFIX defaults to the cloud's path without its extension. Nothing is written when the file cannot be read.
"""
import argparse
import os
import struct
import subprocess
import sys
import tempfile

import numpy as np

from rbpf_slam import atomic, paths

PROG = 'extract_trunks'
COLUMNS = ('x', 'y', 'dbh', 'dbh_sigma', 'points', 'z_min', 'z_max')
LAZ_HINT = "pip install 'laspy[lazrs]'"
#: clouds with more points than this show a progress bar (on a terminal)
PROGRESS_POINTS = 1000000


# --- Reading ----------------------------------------------------------------------------------------------------

def pcd_header(path):
    """The header of a PCD file as a dict of its keys (lists of words); ValueError when it is no PCD header."""
    header = {}
    with open(path, 'rb') as f:
        for _ in range(64):
            raw = f.readline(4096)
            if not raw:
                break
            line = raw.decode('ascii', 'replace').strip()
            if not line or line.startswith('#'):
                continue
            words = line.split()
            header[words[0].upper()] = words[1:]
            if words[0].upper() == 'DATA':
                break
    missing = [k for k in ('FIELDS', 'WIDTH', 'HEIGHT', 'DATA') if k not in header]
    if missing:
        raise ValueError('not a PCD file (no %s in its header)' % ', '.join(missing))
    if header['DATA'][:1] not in (['ascii'], ['binary'], ['binary_compressed']):
        raise ValueError('unknown PCD DATA %s' % ' '.join(header['DATA']))
    if not {'x', 'y', 'z'} <= set(header['FIELDS']):
        raise ValueError('the cloud has no fields x, y and z (fields: %s)' % ' '.join(header['FIELDS']))
    try:
        header['points'] = int(header.get('POINTS', [int(header['WIDTH'][0]) * int(header['HEIGHT'][0])])[0])
    except ValueError:
        raise ValueError('malformed PCD header (POINTS, WIDTH or HEIGHT is not a number)')
    return header


def las_header(data):
    """Point count, record length, data offset, point format, scales and offsets of a LAS header (bytes)."""
    if len(data) < 227 or data[:4] != b'LASF':
        raise ValueError('not a LAS file (truncated header or no LASF signature)')
    header_size, data_offset = struct.unpack_from('<HI', data, 94)
    point_format, record_length, count = struct.unpack_from('<BHI', data, 104)
    scale = np.array(struct.unpack_from('<3d', data, 131))
    offset = np.array(struct.unpack_from('<3d', data, 155))
    if count == 0 and data[25] >= 4 and header_size >= 255 and len(data) >= 255:
        count = struct.unpack_from('<Q', data, 247)[0]
    return {'count': count, 'record_length': record_length, 'data_offset': data_offset,
            'point_format': point_format, 'scale': scale, 'offset': offset}


def read_las(path):
    """The x y z of an uncompressed LAS file as float64 (n × 3); ValueError for a malformed or truncated file."""
    with open(path, 'rb') as f:
        h = las_header(f.read(375))
    if h['point_format'] & 0xC0:
        return read_laz(path)
    if (h['point_format'] & 0x3F) > 10 or h['record_length'] < 12 or h['data_offset'] < 227:
        raise ValueError('malformed LAS header (point format %d, record length %d)'
                         % (h['point_format'], h['record_length']))
    size = os.path.getsize(path)
    held = max(0, size - h['data_offset']) // h['record_length']
    if held < h['count']:
        raise ValueError('truncated: the header announces %d points, the file holds %d' % (h['count'], held))
    if h['count'] == 0:
        return np.zeros((0, 3))
    records = np.memmap(path, mode='r', offset=h['data_offset'], shape=(h['count'],),
                        dtype=np.dtype({'names': ['X', 'Y', 'Z'], 'formats': ['<i4'] * 3, 'offsets': [0, 4, 8],
                                        'itemsize': h['record_length']}))
    xyz = np.empty((h['count'], 3))
    for i, name in enumerate('XYZ'):
        xyz[:, i] = records[name] * h['scale'][i] + h['offset'][i]
    del records
    return xyz


def read_laz(path):
    """The x y z of a LAZ file through laspy; a one-line error naming the module to install when it cannot."""
    try:
        import laspy
    except ImportError:
        raise atomic.UserError('%s: reading LAZ needs the Python module laspy with a LAZ backend: %s'
                               % (path, LAZ_HINT))
    if not laspy.LazBackend.detect_available():
        raise atomic.UserError('%s: laspy has no LAZ backend: install lazrs or laszip (%s)' % (path, LAZ_HINT))
    try:
        las = laspy.read(path)
    except Exception as e:  # laspy's own errors for a malformed or truncated file
        raise ValueError('not a readable LAZ file (%s)' % ' '.join(str(e).split()))
    return np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])


def write_pcd(path, xyz):
    """A binary PCD of float32 x y z."""
    xyz = np.ascontiguousarray(xyz, dtype='<f4')
    with open(path, 'wb') as f:
        f.write(('# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n'
                 'COUNT 1 1 1\nWIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA binary\n'
                 % (len(xyz), len(xyz))).encode('ascii'))
        f.write(xyz.tobytes())


def is_pcd(path):
    with open(path, 'rb') as f:
        start = f.read(4)
    if start == b'LASF':
        return False
    return path.lower().endswith('.pcd') or start[:1] == b'#' or start in (b'VERS', b'FIEL')


def prepare_cloud(path, work):
    """The PCD the finder reads, its point count and the offset to add to its coordinates: the file itself for a
    PCD, else a binary PCD in ``work`` of the LAS/LAZ points about a round offset (float32 keeps millimetres)."""
    if is_pcd(path):
        header = pcd_header(path)
        if header['points'] == 0:
            raise ValueError('the cloud holds no points')
        return path, header['points'], np.zeros(3)
    with open(path, 'rb') as f:
        if f.read(4) != b'LASF' and not path.lower().endswith(('.las', '.laz')):
            raise ValueError('not a PCD, LAS or LAZ file')
    xyz = read_laz(path) if path.lower().endswith('.laz') else read_las(path)
    if len(xyz) == 0:
        raise ValueError('the cloud holds no points')
    offset = np.floor(xyz.min(axis=0)) if np.abs(xyz).max() > 1000.0 else np.zeros(3)
    pcd = os.path.join(work, 'cloud.pcd')
    write_pcd(pcd, xyz - offset)
    return pcd, len(xyz), offset


# --- Finding ----------------------------------------------------------------------------------------------------

def run_finder(cmd, path, show_progress):
    """Run cloud_trunks, relaying its progress to a bar and its warnings to stderr; UserError on its error."""
    bar = None
    if show_progress:
        from tqdm import tqdm
        bar = tqdm(total=100, desc=os.path.basename(path), unit='%', disable=None, leave=False, mininterval=0.5)
    errors = []
    with subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, universal_newlines=True) as proc:
        try:
            for line in proc.stderr:
                words = line.split(None, 1)
                if words and words[0] == 'progress':
                    if bar is not None:
                        bar.update(max(0, int(round(100 * float(words[1]))) - bar.n))
                elif words and words[0] == 'warning:':
                    sys.stderr.write('%s: %s: %s\n' % (PROG, path, words[1].strip()))
                elif line.strip():
                    errors.append(line.strip()[len('error: '):] if line.startswith('error: ') else line.strip())
            proc.wait()
        except atomic.Terminated as e:
            proc.send_signal(e.signum)
            proc.wait()
            raise
        finally:
            if bar is not None:
                bar.close()
    if proc.returncode != 0:
        reason = errors[-1] if errors else 'cloud_trunks failed (%d)' % proc.returncode
        raise atomic.UserError('%s: %s' % (path, reason))


def read_results(out_dir, offset):
    """The trunks (dicts of COLUMNS and lean_deg) and the summary (density grid included) cloud_trunks wrote."""
    trunks = []
    with open(os.path.join(out_dir, 'stems.csv')) as f:
        names = f.readline().strip().split(',')
        for line in f:
            row = dict(zip(names, (float(v) for v in line.split(','))))
            row['x'] += offset[0]
            row['y'] += offset[1]
            row['z_min'] += offset[2]
            row['z_max'] += offset[2]
            row['points'] = int(row['points'])
            trunks.append(row)
    summary = {}
    with open(os.path.join(out_dir, 'summary.txt')) as f:
        for line in f:
            key, value = line.split()
            summary[key] = float(value)
    nx, ny = int(summary['density_nx']), int(summary['density_ny'])
    density = np.fromfile(os.path.join(out_dir, 'density.f32'), dtype='<f4').reshape(ny, nx)
    summary['density_x0'] += offset[0]
    summary['density_y0'] += offset[1]
    return trunks, summary, density


def find_trunks(path, sensor=None, ground_height=None):
    """The trunks of a cloud file and the run's summary and top-view density (see read_results)."""
    with tempfile.TemporaryDirectory(prefix='extract_trunks.') as work:
        pcd, count, offset = prepare_cloud(path, work)
        cmd = [paths.program('cloud_trunks'), pcd, work, '--progress']
        if sensor is not None:
            cmd += ['--sensor', ','.join('%.6f' % v for v in np.asarray(sensor) - offset)]
        if ground_height is not None:
            cmd += ['--ground-height', '%.6f' % (ground_height - offset[2])]
        show = count >= PROGRESS_POINTS or os.path.getsize(path) >= 12 * PROGRESS_POINTS
        run_finder(cmd, path, show)
        return read_results(work, offset)


# --- Writing ----------------------------------------------------------------------------------------------------

def csv_text(trunks):
    lines = [','.join(COLUMNS)]
    for t in trunks:
        lines.append('%.4f,%.4f,%.4f,%.4f,%d,%.3f,%.3f' % tuple(t[c] for c in COLUMNS))
    return '\n'.join(lines) + '\n'


def plot(trunks, summary, density, title):
    """The top view: log point density in grey, each trunk a red circle (to scale) with its row number and DBH."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle
    x0, y0, cell = summary['density_x0'], summary['density_y0'], summary['density_cell']
    ny, nx = density.shape
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.imshow(np.log1p(density), origin='lower', cmap='Greys', interpolation='nearest',
              extent=[x0, x0 + nx * cell, y0, y0 + ny * cell])
    for i, t in enumerate(trunks, 1):
        ax.add_patch(Circle((t['x'], t['y']), 0.5 * t['dbh'], fill=False, ec='tab:red', lw=1.5))
        ax.plot(t['x'], t['y'], '+', color='tab:red', ms=6)
        corner = 0.35 * t['dbh']  # the label starts at the circle's upper right, outside it at any zoom
        ax.annotate('%d: %.1f cm' % (i, 100 * t['dbh']), (t['x'] + corner, t['y'] + corner), xytext=(4, 4),
                    textcoords='offset points', color='tab:red', fontsize=9,
                    bbox={'boxstyle': 'round,pad=0.1', 'fc': 'white', 'ec': 'none', 'alpha': 0.7})
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_aspect('equal')
    ax.set_title('%s: %d trunk%s (DBH at 1.3 m)' % (title, len(trunks), '' if len(trunks) == 1 else 's'))
    fig.tight_layout()
    return fig


def write_outputs(prefix, trunks, summary, density, title):
    """PREFIX_trunks.csv and PREFIX_trunks.png, both or neither."""
    csv_path, png_path = prefix + '_trunks.csv', prefix + '_trunks.png'
    fig = plot(trunks, summary, density, title)
    with atomic.atomic_output(csv_path) as csv_tmp, atomic.atomic_output(png_path) as png_tmp:
        with open(csv_tmp, 'w') as f:
            f.write(csv_text(trunks))
        fig.savefig(png_tmp, format='png', dpi=100)
    return csv_path, png_path


# --- The command ------------------------------------------------------------------------------------------------

def sensor_arg(text):
    try:
        values = [float(v) for v in text.split(',')]
    except ValueError:
        values = []
    if len(values) != 3 or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError('expected X,Y,Z in metres, got %r' % text)
    return values


def main(argv=None):
    """The command: exit code 0; 1 with one line on stderr for a file that cannot be read or written; 2 for a wrong
    command line."""
    return atomic.run_tool(PROG, _main, argv, errors=(ValueError,))


def _main(argv):
    p = argparse.ArgumentParser(prog=PROG, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument('cloud', metavar='CLOUD', help='PCD, LAS or LAZ file')
    p.add_argument('--sensor', metavar='X,Y,Z', type=sensor_arg,
                   help='where the sensor stood, for a scan from a single viewpoint (default: a cloud seen from all '
                        'sides); write --sensor=-4,0,1.8 when X is negative')
    p.add_argument('--out', metavar='PREFIX', help='write PREFIX_trunks.csv and PREFIX_trunks.png (default: the '
                   'cloud\'s path without its extension)')
    p.add_argument('--ground-height', metavar='H', type=float,
                   help='ground height [m] where the cloud shows no ground nearby (default: the median of the '
                        'ground the cloud shows)')
    args = p.parse_args(argv)
    if args.ground_height is not None and not np.isfinite(args.ground_height):
        p.error('--ground-height must be a finite number')
    path = args.cloud
    prefix = args.out if args.out else os.path.splitext(path)[0]
    if not os.path.isfile(path):
        raise atomic.UserError('%s: no such file' % path)
    for out in (prefix + '_trunks.csv', prefix + '_trunks.png'):
        atomic.check_output(out)
    try:
        trunks, summary, density = find_trunks(path, args.sensor, args.ground_height)
    except ValueError as e:
        raise atomic.UserError('%s: %s' % (path, e))
    csv_path, png_path = write_outputs(prefix, trunks, summary, density, os.path.basename(path))
    print('%s: %d points, %d trunk%s -> %s, %s' % (path, int(summary['points_read']), len(trunks),
                                                  '' if len(trunks) == 1 else 's', csv_path, png_path))
    for i, t in enumerate(trunks, 1):
        print('  %2d  x %.3f  y %.3f  DBH %.1f ± %.1f cm  %d points, z %.2f to %.2f m'
              % (i, t['x'], t['y'], 100 * t['dbh'], 100 * t['dbh_sigma'], t['points'], t['z_min'], t['z_max']))
    return 0
