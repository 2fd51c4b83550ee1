"""Shared machinery of the log converters (``*_to_bag``): errors, text parsing, skipped lines, time stamps,
planar kinematics, the summary and the bag output.

Nothing here imports ROS at module level: the parsing and integration functions are plain numpy, so
they can be tested (and reused) without a ROS environment. ROS messages are built in
:mod:`rbpf_slam.convert_msgs`, the bag is opened by :func:`run`.
"""
import argparse
import collections
import errno
import gzip
import heapq
import math
import os
import time
import zipfile
import zlib

import numpy as np

from rbpf_slam.atomic import UserError, atomic_output, check_output, run_tool
from rbpf_slam.geometry import se2_between, se2_compose, wrap_angle  # noqa: F401  (cc.se2_*: the converters)

#: A stamp this much earlier than the latest one before it is not a late clock but garbage (e.g. the
#: uninitialised time stamps of some CARMEN lines): it is rebuilt from the line order, not pooled (see
#: repair_stamps).
MAX_BACKWARD_STEP = 5.0  # [s]
#: ROS time holds the seconds as uint32: a stamp at or past this cannot be written (and is garbage in a log).
ROS_TIME_LIMIT = 2.0 ** 32  # [s]
#: A step forward by more than this (and by more than JUMP_LINES line periods per line) is a jump of a broken
#: clock, not a pause of the logger (see repair_stamps).
MAX_FORWARD_STEP = 3600.0  # [s]
JUMP_LINES = 1000
#: A run of equal stamps that would last longer than this at the log's line period is a stuck clock.
STUCK_SECONDS = 10.0  # [s]
#: A stamp is compared with the median of this many lines on each side of it.
NEIGHBOURS = 10
#: Stamps made strictly increasing move each equal one this much after the one before it.
STAMP_NUDGE = 1e-6  # [s]
#: Where rebuilt stamps start when a log has no trustworthy stamp at all.
REBUILT_START = 1.0  # [s]


class ConversionError(UserError):
    """A malformed input. Its text is ``file:line: expected <what>, got <what was there>`` (one line).

    ``line`` is None for whole-file problems (empty file, wrong .mat layout): ``file: expected ...``.
    """

    def __init__(self, path, line, expected, got=None):
        self.path = str(path)
        self.line = line
        self.expected = expected
        self.got = got
        where = '%s:%d' % (self.path, line) if line else self.path
        text = '%s: expected %s' % (where, expected)
        if got is not None:
            text += ', got %s' % ' '.join(str(got).split())
        super().__init__(text)


QUOTE_LIMIT = 60  # characters of a field of the file quoted in a message


def quote(field):
    """A field of the input file as a message quotes it: its repr, and when that is longer than QUOTE_LIMIT, its
    start and how long it is (the message's own words are never shortened)."""
    text = repr(field)
    if len(text) <= QUOTE_LIMIT:
        return text
    return '%s... (a field of %d characters)' % (text[:QUOTE_LIMIT], len(str(field)))


class BadLines:
    """Malformed lines: the first one stops the conversion, or with ``--skip-bad`` each is counted and
    reported in the summary (by what was expected, with the first few places)."""

    def __init__(self, skip_bad=False, examples=5):
        self.skip_bad = skip_bad
        self.count = 0
        self.reasons = collections.Counter()
        self.examples = []
        self._max_examples = examples

    def __call__(self, error):
        if not self.skip_bad:
            raise error
        self.count += 1
        self.reasons[error.expected] += 1
        if len(self.examples) < self._max_examples:
            self.examples.append(str(error))


# --- Input files and text logs ---------------------------------------------------------------------


def input_file(path):
    """``path`` if it is a file; else an OSError naming what is wrong: a directory, or the file or its folder
    missing (reported by run as ``tool: PATH: reason``)."""
    if os.path.isfile(path):
        return path
    if os.path.isdir(path):
        raise IsADirectoryError(errno.EISDIR, 'is a directory, expected a file', path)
    directory = os.path.dirname(path)
    if directory and os.path.exists(directory) and not os.path.isdir(directory):
        raise NotADirectoryError(errno.ENOTDIR, 'not a directory', directory)
    if directory and not os.path.exists(directory):
        path = directory
    raise FileNotFoundError(errno.ENOENT, os.strerror(errno.ENOENT), path)


def with_gz(directory, name):
    """DIRECTORY/name, or DIRECTORY/name.gz when only that exists (data sets are often shipped gzipped)."""
    path = os.path.join(directory, name)
    return path if os.path.exists(path) or not os.path.exists(path + '.gz') else path + '.gz'


def open_text(path):
    """Open a text log for reading, plain or gzip-compressed (recognised by its magic bytes). A plain file
    with NUL bytes near its start is binary, not a log: ConversionError."""
    with open(input_file(path), 'rb') as f:
        head = f.read(4096)
    if head[:2] == b'\x1f\x8b':
        return gzip.open(path, 'rt', encoding='latin-1', newline=None)
    if b'\x00' in head:
        raise ConversionError(path, None, 'a text log', got='binary data (NUL bytes)')
    return open(path, 'r', encoding='latin-1', newline=None)


def read_tokens(path, limit=None, stream=None):
    """Yield ``(line_number, tokens)`` for every non-blank line of a text log that is not a ``#`` comment.

    Handles CRLF line ends and gzip. A compressed stream cut short or damaged (gzip, or a member of a zip
    archive) raises ConversionError at the line where it ends. ``limit``: stop after that many yielded lines.
    ``stream``: an open text stream to read instead of opening ``path`` (which then only names it in
    messages, e.g. ``archive.zip/member.txt``); it is closed at the end.
    """
    n = 0
    line_no = 0
    with open_text(path) if stream is None else stream as f:
        try:
            for line_no, line in enumerate(f, 1):
                tokens = line.split()
                if not tokens or tokens[0].startswith('#'):
                    continue
                yield line_no, tokens
                n += 1
                if limit is not None and n >= limit:
                    return
        except COMPRESSION_ERRORS as e:
            raise ConversionError(path, line_no + 1, 'more data (the compressed file is cut short or damaged)',
                                  got=e)


#: What reading a compressed stream raises where it is cut short or damaged.
COMPRESSION_ERRORS = (EOFError, zlib.error, gzip.BadGzipFile, zipfile.BadZipFile)


def read_table(path, columns, bad=None, limit=None, until=None, one_past=False, order=None, stream=None):
    """The rows of a text table of numbers, one record a line (blank lines and ``#`` comments skipped): an
    (n, k) float array and the line number of each row (an int array).

    ``columns``: the names of the k fields; the messages say e.g. ``expected time speed steering (3 fields)``.
    A line with another number of fields, or a field that is not a finite number, is malformed (``bad``).
    ``order``: the first field is a time that must ``'increase'`` (strictly) or ``'not decrease'`` from row to
    row; a row against it is malformed. ``limit``: at most that many rows. ``until``: stop before the first
    row timed after it (with ``one_past``, after that row, so that a stream sampled at its own rate covers
    ``until``; no row at all when the first is past it). ``stream``: see read_tokens. A file without a line is
    ``file: expected lines of ..., got an empty file``; one whose every line was malformed (and skipped) likewise,
    ``got no valid line``.
    """
    bad = bad or BadLines()
    names = ' '.join(columns)
    rows, lines = [], []
    previous = None  # (time, its text, its line)
    n_lines = 0
    stopped = False
    for line, tokens in read_tokens(path, stream=stream):
        n_lines += 1
        try:
            require_fields(tokens, len(columns), path, line, names)
            values = parse_floats(tokens, path, line, 'numbers as %s' % names)
            if order is not None and previous is not None and (
                    values[0] < previous[0] or (order == 'increase' and values[0] == previous[0])):
                raise ConversionError(path, line, 'times in %s order' % ('increasing' if order == 'increase' else
                                                                          'non-decreasing'),
                                      got='%s after %s on line %d' % (tokens[0], previous[1], previous[2]))
        except ConversionError as e:
            bad(e)
            continue
        if until is not None and values[0] > until and not (one_past and (not rows or rows[-1][0] < until)):
            stopped = True
            break
        rows.append(values)
        lines.append(line)
        previous = (values[0], tokens[0], line)
        if limit is not None and len(rows) >= limit:
            break
    if not rows and not stopped:
        raise ConversionError(path, None, 'lines of %s' % names, got='no valid line' if n_lines else 'an empty file')
    return np.array(rows, dtype=float).reshape(-1, len(columns)), np.array(lines, dtype=int)


def check_same_clock(path, line, stamps, span, what, slack=60.0):
    """A file whose stamps lie wholly outside ``span`` (first, last) [s] of the stream that sets the clock (by more
    than ``slack`` seconds) is of another log or another release (e.g. Unix-epoch stamps beside stamps from 0):
    ConversionError at ``line``, the line of its first stamp, naming ``what`` sets the clock."""
    first, last = float(np.min(stamps)), float(np.max(stamps))
    if first > span[1] + slack or last < span[0] - slack:
        raise ConversionError(path, line, 'stamps on the clock of %s (%.3f .. %.3f s)' % (what, span[0], span[1]),
                              got='%.3f .. %.3f s (a file of another log or release?)' % (first, last))


def parse_floats(tokens, path, line, what):
    """tokens as float64; a token that is not a finite number (text, nan, inf) raises ConversionError
    naming ``what``."""
    try:
        values = np.array(tokens, dtype=float)
    except ValueError:
        bad = next(t for t in tokens if not _is_float(t))
        raise ConversionError(path, line, what, got=quote(bad))
    finite = np.isfinite(values)
    if not finite.all():
        raise ConversionError(path, line, what, got='%s (not a finite number)' % quote(tokens[int(np.argmin(finite))]))
    return values


def parse_ints(tokens, path, line, what):
    """tokens as int64; a token that is not an integer raises ConversionError naming ``what``."""
    try:
        return np.array([int(t) for t in tokens], dtype=np.int64)
    except ValueError:
        bad = next(t for t in tokens if not _is_int(t))
        raise ConversionError(path, line, what, got=quote(bad))


def _is_float(token):
    try:
        float(token)
        return True
    except ValueError:
        return False


def _is_int(token):
    try:
        int(token)
        return True
    except ValueError:
        return False


def require_fields(tokens, count, path, line, what, exact=True):
    """Check that a line has ``count`` tokens (at least ``count`` when not exact)."""
    if len(tokens) < count or (exact and len(tokens) != count):
        raise ConversionError(path, line, '%s (%d fields)' % (what, count),
                              got='%d field%s' % (len(tokens), '' if len(tokens) == 1 else 's'))


# --- Planar kinematics (REP-103: metres, radians) -------------------------------------------------


# wrap_angle, se2_compose and se2_between: rbpf_slam.geometry (imported above), shared with the evaluator.


def integrate_arcs(ds, dtheta, pose0=(0.0, 0.0, 0.0)):
    """Dead reckoning over steps that each drive an arc of length ``ds`` turning by ``dtheta``.

    Exact for a differential (or skid-steer) drive whose wheel speeds are constant within a step: the
    step moves by the arc's chord, ds * sin(dtheta/2) / (dtheta/2), along the heading halfway through
    the turn. Returns arrays x, y, theta (after each step; theta wrapped to [-pi, pi)).
    """
    ds = np.asarray(ds, dtype=float)
    dtheta = np.asarray(dtheta, dtype=float)
    half = dtheta / 2.0
    chord = ds * np.sinc(half / np.pi)
    heading_before = pose0[2] + np.concatenate(([0.0], np.cumsum(dtheta)[:-1]))
    heading = heading_before + half
    x = pose0[0] + np.cumsum(chord * np.cos(heading))
    y = pose0[1] + np.cumsum(chord * np.sin(heading))
    theta = wrap_angle(pose0[2] + np.cumsum(dtheta))
    return x, y, theta


def integrate_velocities(stamps, v, w, pose0=(0.0, 0.0, 0.0)):
    """Dead reckoning from velocities held from each stamp to the next: forward speed ``v`` [m/s] and yaw rate
    ``w`` [rad/s] of sample k act over [t_k, t_k+1) (exact arcs). Returns the poses at every stamp (x, y, theta
    arrays; the first is ``pose0``) and the arc length and heading change of the step ending at each stamp
    (ds, dtheta; 0 for the first)."""
    dt = np.diff(np.asarray(stamps, dtype=float))
    ds = np.asarray(v, dtype=float)[:-1] * dt
    dth = np.asarray(w, dtype=float)[:-1] * dt
    x, y, th = integrate_arcs(ds, dth, pose0)
    return (np.r_[pose0[0], x], np.r_[pose0[1], y], np.r_[wrap_angle(pose0[2]), th], np.r_[0.0, ds],
            np.r_[0.0, dth])


def polar_covariance(r, bearing, range_sigma, bearing_sigma):
    """Row-major 2 x 2 covariance of the point (r cos b, r sin b) from independent range and bearing noise
    (through the polar-to-Cartesian Jacobian)."""
    c, s = math.cos(bearing), math.sin(bearing)
    j = np.array([[c, -r * s], [s, r * c]])
    cov = j @ np.diag([range_sigma ** 2, bearing_sigma ** 2]) @ j.T
    return tuple(float(v) for v in cov.reshape(-1))


def diff_drive_steps(d_left, d_right, track):
    """Arc length and heading change of each step from the distances the left and right wheels
    (or tracks) travelled: ds = (l + r) / 2, dtheta = (r - l) / track."""
    d_left = np.asarray(d_left, dtype=float)
    d_right = np.asarray(d_right, dtype=float)
    return (d_left + d_right) / 2.0, (d_right - d_left) / float(track)


# --- Time stamps ----------------------------------------------------------------------------------


def isotonic_increasing(values):
    """The non-decreasing sequence closest to ``values`` in the least-squares sense (pool adjacent
    violators). A single late stamp is pulled down to its successor, a single early one up to its
    predecessor: stamps that were in order stay untouched."""
    values = np.asarray(values, dtype=float)
    sums, counts = [], []
    for v in values:
        sums.append(v)
        counts.append(1)
        while len(sums) > 1 and sums[-2] / counts[-2] > sums[-1] / counts[-1]:
            s, c = sums.pop(), counts.pop()
            sums[-1] += s
            counts[-1] += c
    out = np.empty_like(values)
    i = 0
    for s, c in zip(sums, counts):
        out[i:i + c] = s / c
        i += c
    return out


def count_backward(stamps):
    """How many stamps are earlier than the one just before them; how many are earlier than the latest
    one before them (the lines a backward step puts out of order); and the largest such lag [s]."""
    stamps = np.asarray(stamps, dtype=float)
    if len(stamps) < 2:
        return 0, 0, 0.0
    steps = int(np.sum(np.diff(stamps) < 0))
    lag = np.maximum.accumulate(stamps)[:-1] - stamps[1:]
    late = int(np.sum(lag > 0))
    return steps, late, float(lag.max()) if late else 0.0


class TooFewStamps(ValueError):
    """The stamps cannot be rebuilt: no line period was given and the log's own stamps do not show one.
    ``got`` says what the stamps are (for a ConversionError)."""

    def __init__(self, got):
        super().__init__(got)
        self.got = got


#: Why a stamp is garbage, by the code repair_stamps gives it (0: trustworthy).
GARBAGE_REASONS = {
    1: 'not a finite number',
    2: '0 or negative',
    3: 'at or past 2^32 s (out of the range of ROS time)',
    4: 'stuck at one value while the log goes on',
    5: 'far from the median of the lines around them',
    6: 'on a stretch that jumps away from the rest of the log',
    7: 'more than %g s before the latest stamp before them' % MAX_BACKWARD_STEP,
    8: 'all equal: the stamps do not advance',
    9: 'rebuilt on request (every line)',
}


class StampRepair:
    """What repair_stamps found and did. ``stamps``: the stamps to use (non-decreasing); ``code``: 0 for a
    trustworthy stamp, else the key of GARBAGE_REASONS; ``line_period``: the seconds per line used to
    extrapolate (None when nothing was extrapolated), ``period_given``: whether it was given;
    ``backward``: count_backward of the trustworthy stamps as logged; ``n_trusted``: how many stamps were
    trustworthy (before ``rebuild_all``)."""

    def __init__(self, raw, code, stamps, line_period, period_given, backward, n_trusted=0):
        self.n_trusted = n_trusted
        self.raw = raw
        self.code = code
        self.stamps = stamps
        self.line_period = line_period
        self.period_given = period_given
        self.backward = backward

    @property
    def rebuilt(self):
        """Indices of the stamps rebuilt from the line order."""
        return np.flatnonzero(self.code != 0)

    @property
    def trusted(self):
        return np.flatnonzero(self.code == 0)

    def reasons(self):
        """{reason: number of stamps}, in the order of GARBAGE_REASONS."""
        counts = collections.Counter(int(c) for c in self.code if c)
        return collections.OrderedDict((GARBAGE_REASONS[c], counts[c]) for c in sorted(counts))


def typical_line_period(stamps, ok=None, window=50):
    """The seconds per line of a log, robustly: the median of the positive rates (seconds over lines)
    across consecutive windows of ``window`` stamps (only those where ``ok``). None when no window
    advances."""
    stamps = np.asarray(stamps, dtype=float)
    idx = np.flatnonzero(np.ones(len(stamps), dtype=bool) if ok is None else ok)
    if len(idx) < 2:
        return None
    t = stamps[idx]
    w = min(window, len(idx) - 1)
    starts = np.arange(0, len(idx) - w, w)
    rates = (t[starts + w] - t[starts]) / (idx[starts + w] - idx[starts])
    rates = rates[rates > 0]
    return float(np.median(rates)) if len(rates) else None


def repair_stamps(stamps, line_period=None, rebuild_all=False, max_backward=MAX_BACKWARD_STEP):
    """Find the garbage stamps of a log (in file order, one per line) and rebuild them from the line order.

    A stamp is garbage when it is (in this order of tests):

    1. not a finite number, 0 or negative, or at or past 2^32 s (ROS time holds the seconds as uint32);
    2. in a run of equal stamps that would last more than STUCK_SECONDS at the log's line period (a stuck
       clock): every stamp of the run but its first;
    3. further than max(``max_backward``, NEIGHBOURS line periods) from the median of the 2 * NEIGHBOURS + 1
       lines around it, the advance at the line period taken out (a short burst of garbage, up or down);
    4. on a stretch of lines that the rest of the log does not continue: the stamps are cut into stretches
       where they step back more than ``max_backward`` or forward more than MAX_FORWARD_STEP (and more
       than JUMP_LINES line periods per line); the stretches kept are the chain with the most lines in
       which each starts at most ``max_backward`` before the end of the one before and at most such a
       jump after it;
    5. more than ``max_backward`` before the latest trustworthy stamp before it;
    6. with ``line_period`` given, when the trustworthy stamps are all equal: all but the first.

    The line period is the given ``line_period``, else the typical_line_period of the valid stamps (tests
    2 to 4) and the span of the trustworthy stamps over their lines (extrapolation). The trustworthy
    stamps are made non-decreasing by isotonic_increasing; garbage stamps are interpolated by line
    number between the trustworthy ones around them, and before the first / after the last trustworthy
    stamp extrapolated at the line period. ``rebuild_all``: every stamp is put on the line through the
    first trustworthy stamp at the line period (evenly spaced in file order). Without any trustworthy
    stamp the lines are spaced at ``line_period`` from REBUILT_START.

    Raises TooFewStamps when the stamps cannot be rebuilt without a line period: no trustworthy stamp,
    only one (of several lines), or all equal. Returns a StampRepair.
    """
    raw = np.array(stamps, dtype=float)
    n = len(raw)
    code = np.zeros(n, dtype=int)
    if n == 0:
        return StampRepair(raw, code, raw.copy(), None, False, (0, 0, 0.0))
    finite = np.isfinite(raw)
    code[~finite] = 1
    code[finite & (raw <= 0.0)] = 2
    code[finite & (raw >= ROS_TIME_LIMIT)] = 3
    period = line_period if line_period else typical_line_period(raw, code == 0)

    if period:
        _mark_stuck(raw, code, period)
    _mark_far_from_neighbours(raw, code, max(max_backward, NEIGHBOURS * period if period else 0.0), period)
    _mark_cut_off(raw, code, period, max_backward)
    latest = -np.inf
    for i in np.flatnonzero(code == 0):
        if raw[i] < latest - max_backward:
            code[i] = 7
        else:
            latest = max(latest, raw[i])

    trusted = np.flatnonzero(code == 0)
    if len(trusted) > 1 and raw[trusted].min() == raw[trusted].max():
        if not line_period:
            raise TooFewStamps('every stamp %.15g' % raw[trusted[0]] if len(trusted) == n else
                               '%d stamps all %.15g, %d garbage' % (len(trusted), raw[trusted[0]], n - len(trusted)))
        code[trusted[1:]] = 8
        trusted = trusted[:1]
    if not line_period and (len(trusted) == 0 or (len(trusted) == 1 and n > 1)):
        what = ', '.join('%d %s' % (c, r) for r, c in StampRepair(raw, code, None, None, False, None)
                         .reasons().items())
        raise TooFewStamps(('one trustworthy stamp of %d (%s)' % (n, what)) if len(trusted) else
                           ('every stamp 0' if n and np.all(raw == 0.0) else 'no trustworthy stamp (%s)' % what))
    backward = count_backward(raw[trusted])
    lines = np.arange(n, dtype=float)
    out = np.empty(n)
    used_period = None
    if len(trusted) == 0:
        out = REBUILT_START + lines * line_period
        used_period = line_period
    else:
        iso = isotonic_increasing(raw[trusted])
        measured = (iso[-1] - iso[0]) / (trusted[-1] - trusted[0]) if len(trusted) > 1 else None
        step = line_period or measured
        if rebuild_all and step is None:  # a single line
            out = iso.copy()
        elif rebuild_all:
            out = iso[0] + (lines - trusted[0]) * step
            code[code == 0] = 9
            code[trusted[0]] = 0
            used_period = step
        else:
            out[trusted] = iso
            garbage = code != 0
            inside = garbage & (lines > trusted[0]) & (lines < trusted[-1])
            out[inside] = np.interp(lines[inside], trusted, iso)
            before, after = garbage & (lines < trusted[0]), garbage & (lines > trusted[-1])
            out[before] = iso[0] - (trusted[0] - lines[before]) * step if before.any() else 0.0
            out[after] = iso[-1] + (lines[after] - trusted[-1]) * step if after.any() else 0.0
            if before.any() or after.any():
                used_period = step
    return StampRepair(raw, code, out, used_period, bool(line_period) and used_period is not None, backward,
                       len(trusted))


def _mark_stuck(raw, code, period):
    """Code 4 for all but the first stamp of each run of equal valid stamps lasting more than
    STUCK_SECONDS at ``period`` seconds per line."""
    idx = np.flatnonzero(code == 0)
    if len(idx) < 2:
        return
    t = raw[idx]
    starts = np.flatnonzero(np.r_[True, t[1:] != t[:-1]])
    ends = np.r_[starts[1:], len(idx)] - 1
    for s, e in zip(starts, ends):
        if e > s and (idx[e] - idx[s]) * period > STUCK_SECONDS:
            code[idx[s + 1:e + 1]] = 4


def _mark_far_from_neighbours(raw, code, tolerance, period):
    """Code 5 for valid stamps further than ``tolerance`` from the median of the 2 * NEIGHBOURS + 1 valid
    stamps around them (a window kept whole at the ends of the log), the log's advance at ``period``
    seconds per line taken out first (so a line at the end of its window is not far from its centre)."""
    idx = np.flatnonzero(code == 0)
    m = len(idx)
    if m < 3:
        return
    k = min(NEIGHBOURS, (m - 1) // 2)
    width = 2 * k + 1
    t = np.ascontiguousarray(raw[idx] - (period or 0.0) * idx)
    windows = np.lib.stride_tricks.as_strided(t, shape=(m - width + 1, width), strides=(t.strides[0],) * 2,
                                              writeable=False)
    medians = np.median(windows, axis=1)
    centre = np.clip(np.arange(m) - k, 0, m - width)
    code[idx[np.abs(t - medians[centre]) > tolerance]] = 5


def _forward_limit(period, lines):
    return np.maximum(MAX_FORWARD_STEP, JUMP_LINES * period * lines) if period else MAX_FORWARD_STEP


def _mark_cut_off(raw, code, period, max_backward):
    """Code 6 for the valid stamps outside the chain of stretches that tells one story (repair_stamps, 4)."""
    idx = np.flatnonzero(code == 0)
    m = len(idx)
    if m < 2:
        return
    t = raw[idx]
    step = np.diff(t)
    back = step < -max_backward
    splits = np.flatnonzero(back | (step > _forward_limit(period, np.diff(idx)))) + 1
    bounds = np.r_[0, splits, m]
    cuts = set(splits.tolist())
    for j in (np.flatnonzero(back) + 1).tolist():
        # Around a step back, the lines before it that are later than the line after it, and the lines after
        # it that are earlier than the line before it, are stretches of their own (a detour and its return).
        k = int(np.searchsorted(bounds, j))  # bounds[k] == j
        p = j - 1
        while p >= bounds[k - 1] and t[p] > t[j] + max_backward:
            p -= 1
        if p >= bounds[k - 1]:
            cuts.add(p + 1)
        q = j
        while q < bounds[k + 1] and t[q] < t[j - 1] - max_backward:
            q += 1
        if q < bounds[k + 1]:
            cuts.add(q)
    if not cuts:
        return
    starts = np.array([0] + sorted(cuts))
    ends = np.r_[starts[1:], m] - 1
    weight = (ends - starts + 1).astype(float)
    first_t, last_t = t[starts], t[ends]
    first_line, last_line = idx[starts], idx[ends]
    best = np.zeros(len(starts))
    before = np.full(len(starts), -1)
    for j in range(len(starts)):
        i = np.arange(max(0, j - 2000), j)
        gap = first_t[j] - last_t[i]
        ok = (gap >= -max_backward) & (gap <= _forward_limit(period, first_line[j] - last_line[i]))
        best[j] = weight[j]
        if ok.any():
            k = i[ok][int(np.argmax(best[i[ok]]))]
            best[j] += best[k]
            before[j] = k
    keep = np.zeros(len(starts), dtype=bool)
    j = int(np.argmax(best))
    while j >= 0:
        keep[j] = True
        j = before[j]
    for s, e in zip(starts[~keep], ends[~keep]):
        code[idx[s:e + 1]] = 6


def strictly_increasing(stamps, step=STAMP_NUDGE):
    """Stamps (non-decreasing) made strictly increasing: each at least ``step`` after the one before.
    Returns (stamps, how many moved, the largest move [s])."""
    stamps = np.asarray(stamps, dtype=float)
    if len(stamps) == 0:
        return stamps.copy(), 0, 0.0
    k = np.arange(len(stamps)) * step
    out = np.maximum.accumulate(stamps - k) + k
    moved = out - stamps
    return out, int(np.sum(moved > 0)), float(moved.max())


def fix_stamps(stamps, max_backward=MAX_BACKWARD_STEP):
    """Make stamps (in file order) non-decreasing, changing as little as possible.

    Garbage stamps (see repair_stamps: not finite, not positive, past ROS time, stuck, far from their
    neighbours, more than ``max_backward`` seconds before the latest one before them, ...) are rebuilt from
    the line order; the rest are made non-decreasing by :func:`isotonic_increasing`. Returns (fixed stamps,
    count_backward of the trustworthy stamps, number of garbage stamps). Raises TooFewStamps (a ValueError)
    when there is no trustworthy stamp.
    """
    r = repair_stamps(stamps, max_backward=max_backward)
    return r.stamps, r.backward, len(r.rebuilt)


def last_of_equal_runs(stamps, tolerance=1e-6):
    """Indices that keep only the last element of each run of equal stamps (stamps non-decreasing;
    closer than ``tolerance`` [s] counts as equal: bags store nanoseconds, and pooled stamps may differ
    in their last bits)."""
    stamps = np.asarray(stamps, dtype=float)
    if len(stamps) == 0:
        return np.zeros(0, dtype=int)
    keep = np.ones(len(stamps), dtype=bool)
    keep[:-1] = np.diff(stamps) > tolerance
    return np.nonzero(keep)[0]


def spread_equal_stamps(stamps):
    """Stamps printed with too few digits, spread out again by line number. Lines logged at a steady rate whose
    stamps were rounded to the printed digits come in runs of equal stamps (e.g. ``1000.1`` five times at 50 Hz);
    rounding to the nearest digit centres a run's true stamps on the printed value, so each run's middle keeps
    it and the lines between the middles of consecutive runs are interpolated linearly. A run cut by the start or
    the end of the log is not centred on its value: beyond the outermost whole runs the lines go on at the median
    rate of the runs. Stamps all distinct come back unchanged.

    ``stamps`` must not decrease. Returns (stamps, how many lines share a stamp with another, the largest
    move [s]); the stamps returned increase strictly. All equal: a TooFewStamps (they do not advance)."""
    t = np.asarray(stamps, dtype=float)
    if len(t) < 2:
        return t.copy(), 0, 0.0
    starts = np.flatnonzero(np.r_[True, np.diff(t) != 0])
    if len(starts) == len(t):
        return t.copy(), 0, 0.0
    if len(starts) == 1:
        raise TooFewStamps('all %d stamps equal (%.6g s)' % (len(t), t[0]))
    ends = np.r_[starts[1:], len(t)]
    lengths = ends - starts
    whole = np.ones(len(starts), dtype=bool)
    if len(starts) >= 4:  # the first and the last run may be cut by the log's ends
        whole[0], whole[-1] = lengths[0] == 1, lengths[-1] == 1
    centres = ((starts + ends - 1) / 2.0)[whole]
    values = t[starts][whole]
    rate = float(np.median(np.diff(values) / np.diff(centres)))
    k = np.arange(len(t), dtype=float)
    out = np.interp(k, centres, values)
    before, after = k < centres[0], k > centres[-1]
    out[before] = values[0] + (k[before] - centres[0]) * rate
    out[after] = values[-1] + (k[after] - centres[-1]) * rate
    shared = int(np.sum(lengths[lengths > 1]))
    return out, shared, float(np.max(np.abs(out - t)))


# --- Summary and output -----------------------------------------------------------------------------


class Summary:
    """What a conversion wrote (messages per topic, time span), skipped and why, and notes on the data."""

    def __init__(self, prog):
        self.prog = prog
        self.counts = collections.Counter()
        self.first = None
        self.last = None
        self.skipped = collections.Counter()  # reason -> count
        self.notes = []
        self.bad = None
        self.elapsed = None
        self.output = None

    def message(self, topic, stamp):
        self.counts[topic] += 1
        if self.first is None or stamp < self.first:
            self.first = stamp
        if self.last is None or stamp > self.last:
            self.last = stamp

    def skip(self, reason, n=1):
        if n:
            self.skipped[reason] += n

    def note(self, text):
        self.notes.append(text)

    @property
    def span(self):
        return 0.0 if self.first is None else self.last - self.first

    def text(self):
        lines = ['%s: wrote %s' % (self.prog, self.output)]
        if self.first is not None:
            lines.append('  time span %.3f s (stamps %.3f .. %.3f)' % (self.span, self.first, self.last))
        if self.elapsed is not None:
            speed = ('%.0fx faster than the log' % (self.span / self.elapsed)) if self.elapsed > 0 else ''
            lines.append('  converted in %.2f s %s' % (self.elapsed, speed))
        lines.append('  %-34s %10s' % ('topic', 'messages'))
        for topic in sorted(self.counts):
            lines.append('  %-34s %10d' % (topic, self.counts[topic]))
        if self.skipped:
            lines.append('  skipped:')
            for reason, n in sorted(self.skipped.items()):
                lines.append('    %7d  %s' % (n, reason))
        if self.bad is not None and self.bad.count:
            lines.append('  malformed lines skipped (--skip-bad): %d' % self.bad.count)
            for reason, n in self.bad.reasons.most_common():
                lines.append('    %7d  expected %s' % (n, reason))
            for example in self.bad.examples:
                lines.append('      e.g. %s' % example)
        if self.notes:
            lines.append('  notes:')
            lines.extend('    - %s' % n for n in self.notes)
        return '\n'.join(lines)


def ros_topic(name):
    """Topic names in the bag are absolute (``odom`` -> ``/odom``), as rosbag record writes them."""
    return name if name.startswith('/') else '/' + name


class BagOutput:
    """Writes messages to an open rosbag.Bag with the bag time equal to the header stamp, counts them in
    the summary and refuses a stamp going backwards on a topic (that would be a converter bug), or one
    outside ROS time (0 to 2^32 s, the offset included: ConversionError, not a crash in serialisation)."""

    def __init__(self, bag, summary, time_offset=0.0, progress=None):
        self.bag = bag
        self.summary = summary
        self.time_offset = time_offset
        self.progress = progress
        self._last = {}

    def expect(self, n):
        """Tell the progress bar how many messages will be written."""
        if self.progress is not None:
            self.progress.total = n
            self.progress.refresh()

    def write(self, topic, msg, stamp, latch=False):
        from rbpf_slam.convert_msgs import ros_time
        topic = ros_topic(topic)
        if not 0.0 < stamp + self.time_offset < ROS_TIME_LIMIT:
            raise ConversionError(self.summary.output, None, 'time stamps after 0 and before 2^32 s (ROS time 0 is '
                                  'no time; ROS time holds the seconds as uint32)', got='%.6g s on %s%s' % (
                                      stamp + self.time_offset, topic,
                                      ' (with --time-offset %g)' % self.time_offset if self.time_offset else ''))
        last = self._last.get(topic)
        if last is not None and stamp < last:
            raise RuntimeError('internal error: %s stamp %.6f after %.6f' % (topic, stamp, last))
        self._last[topic] = stamp
        if self.time_offset:
            _shift_times(msg, self.time_offset)
        header = None
        if latch:  # rosbag play latches a topic whose connection header says so (as rosbag record writes it)
            header = {'topic': topic, 'type': msg._type, 'md5sum': msg._md5sum,
                      'message_definition': msg._full_text, 'latching': '1'}
        self.bag.write(topic, msg, ros_time(stamp + self.time_offset), connection_header=header)
        self.summary.message(topic, stamp)
        if self.progress is not None:
            self.progress.update(1)

    def write_merged(self, streams):
        """Write several streams of ``(stamp, topic, msg, latch)`` (each in stamp order) in global stamp
        order; at equal stamps the stream listed first goes first (static TF and odometry before the
        scans that need them)."""
        for stamp, topic, msg, latch in heapq.merge(*streams, key=lambda e: e[0]):
            self.write(topic, msg, stamp, latch)


def _shift_times(msg, offset):
    """Add ``offset`` seconds to every ``time`` field of a message, nested ones included (header stamps,
    the transforms of a TFMessage, the poses of a Path)."""
    import rospy
    for slot, slot_type in zip(msg.__slots__, msg._slot_types):
        value = getattr(msg, slot)
        if slot_type == 'time':
            setattr(msg, slot, value + rospy.Duration.from_sec(offset))
        elif hasattr(value, '_slot_types'):
            _shift_times(value, offset)
        elif isinstance(value, list) and value and hasattr(value[0], '_slot_types'):
            for item in value:
                _shift_times(item, offset)


def position_reference(args, stamps, xs, ys):
    """A reference of positions only (a camera's points, GPS fixes) as a stream for BagOutput.write_merged:
    ``args.truth_odom_topic`` (Odometry, orientation identity, child ``args.truth_point_frame``) at each stamp, then
    ``args.truth_path_topic`` (latched Path) at the last, in ``args.map_frame``."""
    from rbpf_slam import convert_msgs as m
    for i in range(len(stamps)):
        t = float(stamps[i])
        yield t, args.truth_odom_topic, m.odometry(t, args.map_frame, args.truth_point_frame, float(xs[i]),
                                                   float(ys[i]), 0.0), False
    t_end = float(stamps[-1])
    yield t_end, args.truth_path_topic, m.path(t_end, args.map_frame, stamps, xs, ys), True


#: [s] Shift of the stamps of data sets whose clock starts at 0: ROS time 0 means "no time" (rosbag refuses it as an
#: index time, TF reads it as "the latest", a node's clock at 0 has not started), so their data begin at 1 s.
ZERO_CLOCK_OFFSET = 1.0


def add_common_arguments(parser, topics=(), frames=(), time_offset=0.0):
    """Options every converter has. ``topics``/``frames``: (option, default, help) triples; ``time_offset``: the
    default of --time-offset (ZERO_CLOCK_OFFSET for data whose clock starts at 0)."""
    parser.add_argument('-o', '--output', required=True, metavar='BAG',
                        help='the bag to write (*.bag; written to a temporary name and renamed when complete)')
    parser.add_argument('--skip-bad', action='store_true',
                        help='skip malformed lines (counted and reported) instead of stopping at the first')
    parser.add_argument('--limit', type=int, default=None, metavar='N',
                        help='convert only the first N records (see above what a record is here)')
    parser.add_argument('--time-offset', type=float, default=time_offset, metavar='S',
                        help='add S seconds to every stamp (default %g%s)' % (
                            time_offset, ': the log\'s own times' if time_offset == 0.0 else
                            ': the data\'s clock starts at 0, which ROS takes as no time'))
    parser.add_argument('--compression', choices=('none', 'bz2', 'lz4'), default='none',
                        help='bag compression (default none)')
    parser.add_argument('-q', '--quiet', action='store_true', help='no progress bar (the summary is still printed)')
    group = parser.add_argument_group('topics')
    for option, default, text in topics:
        group.add_argument(option, default=default, help='%s (default %s)' % (text, default))
    group = parser.add_argument_group('frames')
    for option, default, text in frames:
        group.add_argument(option, default=default, help='%s (default %s)' % (text, default))


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    pass


def make_parser(prog, doc):
    return argparse.ArgumentParser(prog=prog, description=doc, formatter_class=HelpFormatter)


def positive_float(text):
    """argparse type: a number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError('not a number: %r' % text)
    if not value > 0:
        raise argparse.ArgumentTypeError('must be > 0: %r' % text)
    return value


def run(parser, convert, argv=None, expected_messages=None):
    """Parse the command line, convert into a bag atomically and print the summary.

    ``convert(args, out, bad, summary)`` writes through ``out`` (a BagOutput). Returns the exit code:
    0 done; 1 a user error, in one line on stderr (``tool: file:line: expected ...`` for a malformed
    input, ``tool: PATH: reason`` for a missing input or an output that cannot be written), no bag
    written; 130 interrupted, 128 + N after signal N (SIGTERM, SIGHUP): see atomic.run_tool.
    """
    return run_tool(parser.prog, _run, parser, convert, argv, nothing='no bag written')


def _run(parser, convert, argv):
    args = parser.parse_args(argv)
    prog = parser.prog
    check_output(args.output)
    if not args.output.endswith('.bag'):
        parser.error('the output must be a .bag file: %s' % args.output)
    if args.limit is not None and args.limit <= 0:
        parser.error('--limit must be positive')
    summary = Summary(prog)
    bad = BadLines(args.skip_bad)
    summary.bad = bad
    summary = convert_to_bag(convert, args, summary, bad, progress=not args.quiet)
    print(summary.text())
    return 0


def convert_to_bag(convert, args, summary=None, bad=None, progress=False):
    """Run ``convert`` into ``args.output`` atomically; returns the Summary. Raises ConversionError."""
    import rosbag
    summary = summary or Summary(getattr(args, 'prog', 'convert'))
    bad = bad or BadLines(getattr(args, 'skip_bad', False))
    summary.bad = bad
    summary.output = args.output
    started = time.monotonic()
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(unit=' msg', desc=os.path.basename(args.output), disable=None, leave=False, mininterval=0.5)
    try:
        with atomic_output(args.output) as tmp:
            bag = rosbag.Bag(tmp, 'w', compression=args.compression)
            try:
                out = BagOutput(bag, summary, time_offset=args.time_offset, progress=bar)
                convert(args, out, bad, summary)
                if not summary.counts:
                    raise ConversionError(args.output, None, 'at least one message to write', got='none')
            except BaseException:
                try:  # the bag is thrown away: an error closing it (it may be cut in a record) must not hide
                    bag.close()  # the first one, e.g. the signal that stopped the conversion
                except Exception:
                    pass
                raise
            bag.close()
    finally:
        if bar is not None:
            bar.close()
    summary.elapsed = time.monotonic() - started
    return summary
