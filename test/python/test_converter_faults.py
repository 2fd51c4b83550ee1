"""Faults a user meets, fed through the real commands: malformed values, bad output and input paths, empty,
truncated, garbage and binary logs, and SIGTERM / SIGHUP / Ctrl-C in the middle of writing the bag.

Each must end with a non-zero exit code (128 + N after signal N), one line on stderr naming the problem
(never a traceback), and nothing in the output folder: no bag, no hidden partial file.
"""
import gzip
import os
import shutil
import signal
import stat
import subprocess
import sys
import time

import pytest

from bagcheck import ROOT

SCRIPTS = os.path.join(ROOT, 'scripts')
COMMANDS = ('carmen_to_bag', 'ese650_to_bag', 'freiburg_to_bag', 'lego_to_bag', 'mrclam_to_bag',
            'victoria_park_to_bag')


def run(name, *args):
    return subprocess.run([sys.executable, os.path.join(SCRIPTS, name)] + [str(a) for a in args],
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True, timeout=120)


def assert_fails_cleanly(r, name, out_dir, *expected, code=1, left=()):
    """Exit code, one line on stderr starting with the tool's name and holding each of ``expected``,
    no traceback, and nothing in ``out_dir`` besides ``left``."""
    assert r.returncode == code, (r.returncode, r.stdout, r.stderr)
    assert 'Traceback' not in r.stderr, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith(name + ': '), lines[0]
    for text in expected:
        assert str(text) in lines[0], lines[0]
    assert sorted(os.listdir(str(out_dir))) == sorted(left), 'output left behind'
    return lines[0]


# --- minimal valid inputs of each converter --------------------------------------------------------


def odom(x, t):
    return 'ODOM %.3f 0.000 0.000 0.1 0.0 0.0 %.3f host %.3f\n' % (x, t, t)


def flaser(x, t, tag='FLASER', n=180):
    return '%s %d %s %.3f 0 0 %.3f 0 0 %.3f host %.3f\n' % (tag, n, ' '.join(['2.5'] * n), x, x, t, t)


def robotlaser(x, t, n=181):
    return ('ROBOTLASER1 0 -1.5708 3.1416 0.0175 81.9 0.01 0 %d %s 0 %.3f 0 0 %.3f 0 0 0.1 0 0.5 0.5 0 %.3f host '
            '%.3f\n' % (n, ' '.join(['2.5'] * n), x, x, t, t))


def carmen_log(steps=3):
    lines = []
    for i in range(steps):
        lines += [odom(0.1 * i, 1.0 + 0.2 * i), flaser(0.1 * i, 1.1 + 0.2 * i)]
    return ''.join(lines)


def freiburg_dir(d, sensor='ODOMETRY 0 1 0\nSENSOR 1 2 0.1\nODOMETRY 0 1 0\n'):
    d.mkdir(exist_ok=True)
    (d / 'sensor_data.dat').write_text(sensor)
    (d / 'world.dat').write_text('1 3 0\n')
    return d


def lego_dir(d, motors=None, scans=None):
    d.mkdir(exist_ok=True)
    ranges = ' '.join(['500'] * 660)
    (d / 'robot4_motors.txt').write_text(motors if motors is not None else ''.join(
        'M %d %d 0 3000 0 %d 0 3000 0 0 0 6000 0\n' % (t, 10 * t, 10 * t) for t in (100, 200, 300)))
    (d / 'robot4_scan.txt').write_text(scans if scans is not None else ''.join(
        'S %d 660 %s\n' % (t, ranges) for t in (150, 250)))
    return d


def victoria_park_dir(d, laser=None, drs=None):
    """The extracted files of the Victoria Park release, two scans: LASER.txt one tab-separated stream."""
    d.mkdir(exist_ok=True)
    scan = '\t'.join(['5.00'] * 361)
    (d / 'LASER.txt').write_text(laser if laser is not None else '1.000\t%s\t1.200\t%s' % (scan, scan))
    (d / 'DRS.txt').write_text(drs if drs is not None else ''.join(
        '%.3f\t 1.000\t0.0100\r\n' % (1.0 + 0.025 * k) for k in range(9)))
    (d / 'GPS.txt').write_text('0.000\t  0.00\t  0.00\r\n1.001\t  0.05\t -0.08\r\n')
    return d


def mrclam_dir(d, odometry=None):
    """One robot of the MR.CLAM data set, plain files."""
    d.mkdir(exist_ok=True)
    (d / 'Robot1_Odometry.dat').write_text(odometry if odometry is not None else ''.join(
        '%g 0.1 0.05\n' % (0.02 * k) for k in range(50)))
    (d / 'Robot1_Measurement.dat').write_text('0.5 72 1.5 0.1\n0.5 14 2.0 0.0\n')
    (d / 'Barcodes.dat').write_text('# Subject #    Barcode #\n1 5\n2 14\n6 72\n')
    return d


def encoders_mat(path, compress=False):
    import numpy as np
    import scipy.io
    ts = 1000.0 + 0.025 * np.arange(200)
    scipy.io.savemat(str(path), {'Encoders': {'counts': np.ones((4, 200)), 'ts': ts.reshape(1, -1)}},
                     do_compression=compress)
    return path


@pytest.fixture
def out_dir(tmp_path):
    d = tmp_path / 'out'
    d.mkdir()
    return d


def valid_input(name, tmp_path):
    """Arguments of a conversion that succeeds, for each command."""
    if name == 'carmen_to_bag':
        log = tmp_path / 'ok.log'
        log.write_text(carmen_log())
        return [log]
    if name == 'freiburg_to_bag':
        return [freiburg_dir(tmp_path / 'freiburg')]
    if name == 'lego_to_bag':
        return [lego_dir(tmp_path / 'lego')]
    if name == 'victoria_park_to_bag':
        return [victoria_park_dir(tmp_path / 'vp')]
    if name == 'mrclam_to_bag':
        return [mrclam_dir(tmp_path / 'mrclam'), '--robot', '1']
    d = tmp_path / 'ese'
    d.mkdir()
    encoders_mat(d / 'Encoders7.mat')
    return [d, '7']


@pytest.mark.parametrize('name', COMMANDS)
def test_valid_input_converts_and_leaves_only_the_bag(tmp_path, out_dir, name):
    """The control case of the tests below: the same inputs, a writable folder, success."""
    r = run(name, *valid_input(name, tmp_path), '-o', out_dir / 'x.bag', '-q')
    assert r.returncode == 0, r.stderr
    assert os.listdir(str(out_dir)) == ['x.bag']


# --- 1. values that are not finite numbers in CARMEN lines ----------------------------------------


def _replace_field(line, index, token):
    fields = line.split()
    fields[index] = token
    return ' '.join(fields) + '\n'


CARMEN_BAD_VALUES = [
    # (line builder, field index, token, what the message says was expected)
    (lambda: odom(0.1, 1.2), 1, 'nan', 'expected numbers in the ODOM fields x y theta'),
    (lambda: odom(0.1, 1.2), 3, 'inf', 'expected numbers in the ODOM fields x y theta'),
    (lambda: odom(0.1, 1.2), 7, '-inf', 'expected numbers in the ODOM fields x y theta'),
    (lambda: odom(0.1, 1.2), 2, 'abc', 'expected numbers in the ODOM fields x y theta'),
    (lambda: flaser(0.1, 1.3), 5, 'nan', 'expected numbers as FLASER readings'),
    (lambda: flaser(0.1, 1.3), 2 + 180, 'inf', 'expected numbers in the FLASER pose and timestamp fields'),
    (lambda: flaser(0.1, 1.3), 2 + 180 + 6, 'NaN', 'expected numbers in the FLASER pose and timestamp fields'),
    (lambda: flaser(0.1, 1.3), 7, 'x2.5', 'expected numbers as FLASER readings'),
    (lambda: flaser(0.1, 1.3, 'RLASER'), 9, 'nan', 'expected numbers as RLASER readings'),
    (lambda: flaser(0.1, 1.3, 'RLASER'), 2 + 180 + 1, 'Infinity', 'expected numbers in the RLASER pose'),
    (lambda: robotlaser(0.1, 1.3), 9 + 3, 'nan', 'expected numbers as ROBOTLASER1 readings'),
    (lambda: robotlaser(0.1, 1.3), 3, 'inf', 'expected numbers as ROBOTLASER1 start_angle fov'),
]


@pytest.mark.parametrize('make, index, token, expected', CARMEN_BAD_VALUES,
                         ids=['%s-%d-%s' % (m().split()[0], i, t) for m, i, t, _ in CARMEN_BAD_VALUES])
def test_carmen_value_that_is_not_a_finite_number(tmp_path, out_dir, make, index, token, expected):
    log = tmp_path / 'bad.log'
    log.write_text(carmen_log(2) + _replace_field(make(), index, token) + carmen_log(1))
    r = run('carmen_to_bag', log, '-o', out_dir / 'x.bag', '-q')
    assert_fails_cleanly(r, 'carmen_to_bag', out_dir, '%s:5: %s' % (log, expected), "got '%s'" % token)


def test_non_finite_values_in_the_other_text_formats(tmp_path, out_dir):
    d = freiburg_dir(tmp_path / 'f', 'ODOMETRY 0 1 0\nODOMETRY 0 inf 0\n')
    assert_fails_cleanly(run('freiburg_to_bag', d, '-o', out_dir / 'x.bag'), 'freiburg_to_bag', out_dir,
                         'sensor_data.dat:2: expected numbers as r1 t r2', "got 'inf' (not a finite number)")
    d = lego_dir(tmp_path / 'l', scans='S 150 660 %s nan\n' % ' '.join(['500'] * 659))
    assert_fails_cleanly(run('lego_to_bag', d, '-o', out_dir / 'x.bag'), 'lego_to_bag', out_dir,
                         'robot4_scan.txt:1: expected numbers as ranges', "got 'nan'")


# --- 2. the output path ----------------------------------------------------------------------------


@pytest.mark.parametrize('name', COMMANDS)
def test_output_is_an_existing_directory(tmp_path, out_dir, name):
    args = valid_input(name, tmp_path)
    (out_dir / 'x.bag').mkdir()
    assert_fails_cleanly(run(name, *args, '-o', out_dir / 'x.bag'), name, out_dir,
                         '%s: is a directory' % (out_dir / 'x.bag'), left=['x.bag'])
    assert os.listdir(str(out_dir / 'x.bag')) == []
    # a folder given without a file name: the same one line, not a usage message
    assert_fails_cleanly(run(name, *args, '-o', out_dir), name, out_dir, '%s: is a directory' % out_dir,
                         left=['x.bag'])


@pytest.mark.parametrize('name', COMMANDS)
def test_output_folder_does_not_exist(tmp_path, out_dir, name):
    r = run(name, *valid_input(name, tmp_path), '-o', out_dir / 'nowhere' / 'x.bag')
    assert_fails_cleanly(r, name, out_dir, '%s: the output folder does not exist' % (out_dir / 'nowhere'))


@pytest.mark.parametrize('name', COMMANDS)
def test_output_folder_is_a_regular_file(tmp_path, out_dir, name):
    """Not permitted for anyone, root included: a file cannot hold another one."""
    (out_dir / 'file.txt').write_text('x')
    r = run(name, *valid_input(name, tmp_path), '-o', out_dir / 'file.txt' / 'x.bag')
    assert_fails_cleanly(r, name, out_dir, '%s: not a directory' % (out_dir / 'file.txt'), left=['file.txt'])
    assert (out_dir / 'file.txt').read_text() == 'x'


@pytest.fixture
def read_only_dir(out_dir):
    """A folder nobody may write in: mode 0555, and for root (who ignores the mode) the immutable attribute."""
    out_dir.chmod(0o555)
    immutable = False
    try:
        if os.geteuid() == 0:
            chattr = shutil.which('chattr')
            if not chattr or subprocess.run([chattr, '+i', str(out_dir)], stderr=subprocess.PIPE).returncode != 0:
                pytest.skip('running as root and this file system has no immutable attribute (chattr +i): a '
                            'folder root cannot write in cannot be made here')
            immutable = True
        probe = out_dir / 'probe'
        try:
            probe.write_text('x')
        except OSError:
            pass
        else:
            probe.unlink()
            pytest.skip('%s is still writable' % out_dir)
        yield out_dir
    finally:
        if immutable:
            subprocess.run([shutil.which('chattr'), '-i', str(out_dir)])
        out_dir.chmod(0o755)


@pytest.mark.parametrize('name', COMMANDS)
def test_output_folder_is_read_only(tmp_path, read_only_dir, name):
    r = run(name, *valid_input(name, tmp_path), '-o', read_only_dir / 'x.bag')
    line = assert_fails_cleanly(r, name, read_only_dir, '%s: ' % (read_only_dir / 'x.bag'))
    assert 'permission denied' in line or 'operation not permitted' in line or 'read-only' in line, line


@pytest.mark.parametrize('name', COMMANDS)
def test_stamps_past_ros_time_are_refused(tmp_path, out_dir, name):
    """ROS time holds the seconds as uint32: a stamp past 2^32 s (here from --time-offset) is one line on stderr
    and no bag, not a crash while writing."""
    r = run(name, *valid_input(name, tmp_path), '-o', out_dir / 'x.bag', '-q', '--time-offset', '5e9')
    line = assert_fails_cleanly(r, name, out_dir, 'expected time stamps')
    assert '2^32 s' in line and 'got 5' in line, line


# --- 2. the inputs ---------------------------------------------------------------------------------


def _bytes(n=4000):
    """Binary data (with NUL bytes), the same in every run."""
    return bytes((i * 7919 + 13) % 256 for i in range(n))


def _gzip_cut(text):
    whole = gzip.compress(text.encode())
    return whole[:len(whole) // 2]


def carmen_case(tmp_path, case):
    log = tmp_path / 'in.log'
    if case == 'missing':
        return [log], '%s: no such file or directory' % log
    if case == 'directory':
        log.mkdir()
        return [log], '%s: is a directory' % log
    if case == 'empty':
        log.write_text('')
        return [log], '%s: expected CARMEN log lines (ODOM, FLASER, ...), got an empty file' % log
    if case == 'truncated':
        log.write_text(carmen_log(3) + flaser(0.5, 2.0)[:300])
        return [log], '%s:7: expected FLASER n, 180 readings' % log
    if case == 'truncated gzip':
        log = tmp_path / 'in.log.gz'
        log.write_bytes(_gzip_cut(carmen_log(200)))
        return [log], 'expected more data (the compressed file is cut short or damaged)'
    if case == 'garbage':
        log.write_text('Lorem ipsum dolor sit amet\nconsectetur adipiscing elit\n')
        return [log], "%s: expected at least one ODOM, FLASER, RLASER, ROBOTLASER1 or TRUEPOS line, got none" % log
    log.write_bytes(_bytes())
    return [log], '%s: expected a text log, got binary data' % log


def freiburg_case(tmp_path, case):
    d = tmp_path / 'in'
    data = d / 'sensor_data.dat'
    if case == 'missing':
        return [d], '%s: no such file or directory' % d
    if case == 'directory':
        freiburg_dir(d)
        (d / 'sub').mkdir()
        return [d, '--sensor-data', d / 'sub'], '%s: is a directory' % (d / 'sub')
    freiburg_dir(d)
    if case == 'empty':
        data.write_text('')
        return [d], '%s: expected "ODOMETRY r1 t r2" and "SENSOR id range bearing" lines, got an empty file' % data
    if case == 'truncated':
        data.write_text('ODOMETRY 0 1 0\nSENSOR 1 2 0.1\nODOMETRY 0.1 0.')
        return [d], '%s:3: expected ODOMETRY r1 t r2 (4 fields), got 3 fields' % data
    if case == 'truncated gzip':
        data.write_bytes(_gzip_cut('ODOMETRY 0 1 0\nSENSOR 1 2 0.1\n' * 300))
        return [d], 'expected more data (the compressed file is cut short or damaged)'
    if case == 'garbage':
        data.write_text('Lorem ipsum dolor sit amet\n')
        return [d], "%s:1: expected a line starting with 'ODOMETRY' or 'SENSOR', got 'Lorem'" % data
    data.write_bytes(_bytes())
    return [d], '%s: expected a text log, got binary data' % data


def lego_case(tmp_path, case):
    d = tmp_path / 'in'
    motors = d / 'robot4_motors.txt'
    if case == 'missing':
        return [d], '%s: no such file or directory' % d
    lego_dir(d)
    if case == 'directory':
        (d / 'sub').mkdir()
        return [d, '--motors', d / 'sub'], '%s: is a directory' % (d / 'sub')
    if case == 'empty':
        motors.write_text('')
        return [d], '%s: expected motor records "M ts left ... right ...", got an empty file' % motors
    if case == 'truncated':
        scan = d / 'robot4_scan.txt'
        scan.write_text(scan.read_text()[:-1500])
        return [d], '%s:2: expected S ts n and 660 ranges' % scan
    if case == 'truncated gzip':
        motors.write_bytes(_gzip_cut('M 100 0 0 3000 0 0 0 3000 0 0 0 6000 0\n' * 500))
        return [d], 'expected more data (the compressed file is cut short or damaged)'
    if case == 'garbage':
        motors.write_text('Lorem ipsum dolor sit amet\n')
        return [d], "%s:1: expected a line starting with 'M', got 'Lorem'" % motors
    motors.write_bytes(_bytes())
    return [d], '%s: expected a text log, got binary data' % motors


def ese650_case(tmp_path, case):
    d = tmp_path / 'in'
    enc = d / 'Encoders7.mat'
    if case == 'missing':
        return [d, '7'], '%s: no such file or directory' % d
    d.mkdir()
    if case == 'directory':
        enc.mkdir()
        return [d, '7'], '%s: is a directory' % enc
    if case == 'empty':
        enc.write_bytes(b'')
    elif case == 'truncated':
        whole = encoders_mat(tmp_path / 'whole.mat').read_bytes()
        enc.write_bytes(whole[:len(whole) // 2])
    elif case == 'truncated gzip':  # a compressed .mat file, cut in its compressed data
        whole = encoders_mat(tmp_path / 'whole.mat', compress=True).read_bytes()
        enc.write_bytes(whole[:len(whole) // 2])
    elif case == 'garbage':
        enc.write_text('Lorem ipsum dolor sit amet\n')
    else:
        enc.write_bytes(_bytes())
    return [d, '7'], '%s: expected a MATLAB .mat file, got ' % enc


def victoria_park_case(tmp_path, case):
    d = tmp_path / 'in'
    laser = d / 'LASER.txt'
    if case == 'missing':
        return [d], '%s: no such file or directory' % d
    victoria_park_dir(d)
    if case == 'directory':
        (d / 'sub').mkdir()
        return [d, '--laser', d / 'sub'], '%s: is a directory' % (d / 'sub')
    if case == 'empty':
        laser.write_text('')
        return [d], '%s: expected scans of a time and 361 ranges, got an empty file' % laser
    if case == 'truncated':
        laser.write_text(laser.read_text()[:-1500])
        return [d], '%s:1: expected a time and 361 ranges (362 numbers) in scan 2, got ' % laser
    drs = d / 'DRS.txt'
    if case == 'truncated gzip':
        drs.write_bytes(_gzip_cut('1.000\t 1.000\t0.0100\n' * 500))
        return [d], 'expected more data (the compressed file is cut short or damaged)'
    if case == 'garbage':
        drs.write_text('Lorem ipsum dolor sit amet\n')
        return [d], '%s:1: expected time speed steering (3 fields), got 5 fields' % drs
    laser.write_bytes(_bytes())
    return [d], '%s: expected a text log, got binary data' % laser


def mrclam_case(tmp_path, case):
    d = tmp_path / 'in'
    odometry = d / 'Robot1_Odometry.dat'
    if case == 'missing':
        return [d, '--robot', '1'], '%s: no such file or directory' % d
    mrclam_dir(d)
    if case == 'directory':
        (d / 'sub').mkdir()
        return [d, '--robot', '1', '--odometry', d / 'sub'], '%s: is a directory' % (d / 'sub')
    if case == 'empty':
        odometry.write_text('')
        return [d, '--robot', '1'], '%s: expected lines of time v w, got an empty file' % odometry
    if case == 'truncated':
        odometry.write_text(odometry.read_text()[:-6])
        return [d, '--robot', '1'], '%s:50: expected time v w (3 fields), got 2 fields' % odometry
    if case == 'truncated gzip':
        odometry.write_bytes(_gzip_cut(''.join('%g 0.1 0.05\n' % (0.02 * k) for k in range(3000))))
        return [d, '--robot', '1'], 'expected more data (the compressed file is cut short or damaged)'
    if case == 'garbage':
        odometry.write_text('Lorem ipsum dolor sit amet\n')
        return [d, '--robot', '1'], '%s:1: expected time v w (3 fields), got 5 fields' % odometry
    odometry.write_bytes(_bytes())
    return [d, '--robot', '1'], '%s: expected a text log, got binary data' % odometry


CASES = ('missing', 'directory', 'empty', 'truncated', 'truncated gzip', 'garbage', 'binary')
MAKERS = {'carmen_to_bag': carmen_case, 'freiburg_to_bag': freiburg_case, 'lego_to_bag': lego_case,
          'ese650_to_bag': ese650_case, 'mrclam_to_bag': mrclam_case, 'victoria_park_to_bag': victoria_park_case}


@pytest.mark.parametrize('case', CASES)
@pytest.mark.parametrize('name', COMMANDS)
def test_bad_input(tmp_path, out_dir, name, case):
    args, expected = MAKERS[name](tmp_path, case)
    assert_fails_cleanly(run(name, *args, '-o', out_dir / 'x.bag', '-q'), name, out_dir, expected)


# --- 1. signals in the middle of writing -----------------------------------------------------------


@pytest.fixture(scope='module')
def big_log(tmp_path_factory):
    """A synthetic CARMEN log of 20000 lines (odometry and 180-beam scans, about 8 MB): several seconds
    of writing. A scan's pose is odometry at its time, 5 mm on from the ODOM line before it (ODOM lines that
    repeat the scans' poses would be refused)."""
    path = tmp_path_factory.mktemp('big') / 'big.log'
    with open(str(path), 'w') as f:
        for i in range(10000):
            f.write(odom(0.01 * i, 1.0 + 0.1 * i))
            f.write(flaser(0.01 * i + 0.005, 1.05 + 0.1 * i))
    return path


def _partial(out_dir):
    names = [n for n in os.listdir(str(out_dir)) if '.partial' in n]
    return os.path.join(str(out_dir), names[0]) if names else None


def _default_sigint():
    """In the child: SIGINT and SIGHUP as a terminal gives them. A shell starts background jobs with SIGINT ignored
    (and nohup SIGHUP), and Python then keeps ignoring them; the tool must be tested as a user at a terminal runs
    it."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGHUP, signal.SIG_DFL)


@pytest.mark.parametrize('signum', [signal.SIGTERM, signal.SIGHUP, signal.SIGINT], ids=lambda s: s.name)
def test_signal_while_writing_leaves_no_file(big_log, out_dir, signum):
    proc = subprocess.Popen([sys.executable, os.path.join(SCRIPTS, 'carmen_to_bag'), str(big_log),
                             '-o', str(out_dir / 'big.bag'), '-q'],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                            preexec_fn=_default_sigint)
    try:
        deadline = time.monotonic() + 60
        partial = None
        while time.monotonic() < deadline and proc.poll() is None:  # wait until messages are being written
            partial = _partial(out_dir)
            try:
                if partial and os.path.getsize(partial) > 256 * 1024:
                    break
            except OSError:
                pass
            time.sleep(0.02)
        assert proc.poll() is None, 'the conversion ended before it could be interrupted'
        assert partial and os.path.basename(partial).startswith('.big.partial-'), os.listdir(str(out_dir))
        proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    r = subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)
    expected = 'interrupted, no bag written' if signum == signal.SIGINT else \
        'terminated by %s, no bag written' % signum.name
    assert_fails_cleanly(r, 'carmen_to_bag', out_dir, expected, code=130 if signum == signal.SIGINT else 128 + signum)
    assert stdout == ''


def test_a_second_signal_does_not_stop_the_clean_up(big_log, out_dir):
    proc = subprocess.Popen([sys.executable, os.path.join(SCRIPTS, 'carmen_to_bag'), str(big_log),
                             '-o', str(out_dir / 'big.bag'), '-q'],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True,
                            preexec_fn=_default_sigint)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None and not _partial(out_dir):
            time.sleep(0.02)
        assert proc.poll() is None and _partial(out_dir)
        for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGTERM, signal.SIGHUP):
            proc.send_signal(signum)
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    # The first one handled (SIGHUP when both are pending at once: lower numbers go first) ends the tool.
    first = signal.SIGHUP if 'SIGHUP' in stderr else signal.SIGTERM
    r = subprocess.CompletedProcess(proc.args, proc.returncode, stdout, stderr)
    assert_fails_cleanly(r, 'carmen_to_bag', out_dir, 'terminated by %s, no bag written' % first.name,
                         code=128 + first)


# --- the other tools: one-line errors, atomic outputs ----------------------------------------------


def _tum(path, n=5):
    path.write_text(''.join('%d.0 %d.0 0 0 0 0 0 1\n' % (i, i) for i in range(n)))
    return path


def test_plot_grid_run_writes_only_the_png(tmp_path, out_dir):
    r = run('plot_grid_run', '--paths', _tum(tmp_path / 'a.tum'), '--out', out_dir / 'paths.png')
    assert r.returncode == 0, r.stderr
    assert os.listdir(str(out_dir)) == ['paths.png']
    assert (out_dir / 'paths.png').read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


@pytest.mark.parametrize('case', ['missing folder', 'folder is a file', 'output is a directory', 'bad input',
                                  'missing input'])
def test_plot_grid_run_errors(tmp_path, out_dir, case):
    tum = _tum(tmp_path / 'a.tum')
    out, left = out_dir / 'paths.png', []
    if case == 'missing folder':
        out, expected = out_dir / 'no' / 'p.png', '%s: the output folder does not exist' % (out_dir / 'no')
    elif case == 'folder is a file':
        (out_dir / 'f').write_text('')
        out, expected, left = out_dir / 'f' / 'p.png', '%s: not a directory' % (out_dir / 'f'), ['f']
    elif case == 'output is a directory':
        out.mkdir()
        expected, left = '%s: is a directory' % out, ['paths.png']
    elif case == 'bad input':
        tum.write_text('0 1 2\n')
        expected = '%s: expected 8 columns' % tum
    else:
        tum, expected = tmp_path / 'none.tum', 'none.tum'
    r = run('plot_grid_run', '--paths', tum, '--out', out)
    assert_fails_cleanly(r, 'plot_grid_run', out_dir, expected, left=left)


def test_evaluate_bag_run_errors_are_one_line(tmp_path):
    run_dir = tmp_path / 'run'
    run_dir.mkdir()
    r = run('evaluate_bag_run', '--bag', tmp_path / 'x.bag', '--run', run_dir)
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, 'estimate.tum')
    _tum(run_dir / 'estimate.tum')
    (tmp_path / 'x.bag').write_bytes(_bytes())
    r = run('evaluate_bag_run', '--bag', tmp_path / 'x.bag', '--run', run_dir)
    assert_fails_cleanly(r, 'evaluate_bag_run', run_dir, '%s: not a readable bag' % (tmp_path / 'x.bag'),
                         left=['estimate.tum'])


def test_read_only_folder_probe_is_real(read_only_dir):
    """The read-only fixture really refuses a write (else the read-only tests above could not fail)."""
    with pytest.raises(OSError):
        (read_only_dir / 'x').write_text('x')
    assert not stat.S_IWUSR & os.stat(str(read_only_dir)).st_mode
