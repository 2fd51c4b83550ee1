"""carmen_to_bag: synthetic logs with known raw motion, malformed inputs, the real Intel, ACES and CSAIL logs."""
import gzip
import math
import os

import numpy as np
import pytest

from bagcheck import (assert_stamps_monotonic, connection_latched, data_path, frames_of, pose2, read_bag,
                      run_main, static_transforms)
from rbpf_slam import carmen
from rbpf_slam import convert_common as cc

pytest.importorskip('rosbag')

HEAD = '# CARMEN Logfile\nPARAM robot_frontlaser_offset 0.1 nohost 0\n'


def odom_line(pose, ts):
    return 'ODOM %.6f %.6f %.6f 0 0 0 %.10g pippo %.10g\n' % (pose[0], pose[1], pose[2], ts, ts)


def flaser_line(ranges, pose, ts):
    r = ' '.join('%.2f' % v for v in ranges)
    p = '%.6f %.6f %.6f' % tuple(pose)
    return 'FLASER %d %s %s %s %.6f pippo %.6f\n' % (len(ranges), r, p, p, ts, ts)


def corrected_log(reset_stamps=(0.0, 0.0, 1e-42)):
    """A corrected log in the Radish layout, and the true raw odometry poses it must give back.

    Raw odometry drives an arc; at each scan the offline SLAM "corrects" the pose by a made-up offset,
    the ODOM line after the scan resets to it, and later ODOM lines add the raw increments to it.
    """
    steps = [(0.1, 0.0, 0.05)] * 12
    raw = [(0.0, 0.0, 0.0)]
    for s in steps:
        raw.append(cc.se2_compose(raw[-1], s))
    text = HEAD
    logged = raw[0]
    ts = 1.0
    text += odom_line(logged, ts)
    expected = [raw[0]]
    resets = iter(reset_stamps)
    for k in range(1, len(raw)):
        ts += 0.1
        logged = cc.se2_compose(logged, cc.se2_between(raw[k - 1], raw[k]))
        text += odom_line(logged, ts)
        expected.append(raw[k])
        if k % 4 == 0:
            corrected = cc.se2_compose(logged, (0.3, -0.2, 0.4))  # the offline SLAM's correction
            text += flaser_line([1.0 + 0.01 * i for i in range(180)], corrected, ts)
            text += odom_line(corrected, next(resets))
            text += 'NEFF 15\n'
            logged = corrected
    return text, expected


def write(tmp_path, name, text, compress=False):
    path = tmp_path / name
    if compress:
        with gzip.open(str(path), 'wt') as f:
            f.write(text)
    else:
        path.write_text(text)
    return str(path)


def test_raw_odometry_is_rebuilt_across_resets_and_never_sees_the_correction(tmp_path, capsys):
    text, expected = corrected_log()
    log = write(tmp_path, 'c.log', text)
    out = str(tmp_path / 'c.bag')
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q'], capsys)
    assert code == 0
    bag = read_bag(out)
    odom = [pose2(m) for _, m in bag['/odom']]
    # One sample per raw ODOM line, and at each scan (after raw poses 4, 8 and 12) one more holding the pose
    # of the ODOM line before it.
    with_scans = [p for k, p in enumerate(expected) for _ in range(2 if k and k % 4 == 0 else 1)]
    assert len(odom) == len(with_scans) == len(expected) + 3
    np.testing.assert_allclose(np.array(odom), np.array(with_scans), atol=2e-6)
    # The reference path is the corrected pose of each scan, in map.
    ref = [pose2(m) for _, m in bag['/ground_truth/odom']]
    assert len(ref) == 3 and frames_of(bag, '/ground_truth/odom') == {'map'}
    assert abs(ref[0][0] - expected[4][0]) > 0.1  # the correction is in the reference, not the odometry
    # All three resets found, one of them with a garbage stamp; ODOM as logged would jump at each.
    assert 'reset' in stdout and '1 of them with a time stamp other than 0' in stdout
    assert_stamps_monotonic(bag)


def test_naive_odometry_would_leak_the_correction():
    text, expected = corrected_log()
    poses = []
    for line in text.splitlines():
        w = line.split()
        if w and w[0] == 'ODOM' and float(w[7]) > 1e-30:
            poses.append((float(w[1]), float(w[2]), float(w[3])))
    assert np.max(np.abs(np.array(poses) - np.array(expected))) > 0.1


def test_rebuild_raw_odometry_unit():
    a, b, c = (0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0)
    reset = (5.0, 5.0, math.pi / 2)
    after = cc.se2_compose(reset, (1.0, 0.0, 0.0))
    out = carmen.rebuild_raw_odometry([a, b, reset, after, c], [False, False, True, False, False])
    np.testing.assert_allclose(out[:3], [a, b, (2.0, 0.0, 0.0)], atol=1e-12)
    # after -> c is a jump of the logged pose, chained as it is (it is not a reset)
    assert len(out) == 4


def test_no_returns_become_inf_and_laser_is_mounted(tmp_path):
    text = HEAD + odom_line((0, 0, 0), 1.0)
    for k in range(12):
        ranges = [2.0] * 180
        ranges[k] = 81.83
        text += flaser_line(ranges, (0, 0, 0), 1.0 + 0.1 * k) + odom_line((0, 0, 0), 1.05 + 0.1 * k)
    log = write(tmp_path, 'm.log', text)
    out = str(tmp_path / 'm.bag')
    assert carmen.main([log, '-o', out, '-q', '--corrected', 'no']) == 0
    bag = read_bag(out)
    scans = [m for _, m in bag['/scan']]
    assert len(scans) == 12
    for k, s in enumerate(scans):
        r = np.array(s.ranges)
        assert np.isinf(r[k]) and r[k] > 0 and np.sum(np.isinf(r)) == 1
        assert np.allclose(np.delete(r, k), 2.0)
        assert s.angle_min == pytest.approx(-math.pi / 2) and s.angle_increment == pytest.approx(math.pi / 180)
        assert s.header.frame_id == 'laser' and s.range_max <= 81.83
    tf = static_transforms(bag)[('base_link', 'laser')]
    assert tf.transform.translation.x == pytest.approx(0.1)
    assert connection_latched(out, '/tf_static')
    assert '/ground_truth/odom' not in bag  # not a corrected log: laser poses are no reference


def ranges_log(scans, head=HEAD):
    """ODOM and FLASER lines, the robot standing still; ``scans``: the readings of each scan."""
    text = head + odom_line((0, 0, 0), 1.0)
    for k, ranges in enumerate(scans):
        text += flaser_line(ranges, (0, 0, 0), 1.0 + 0.1 * k) + odom_line((0, 0, 0), 1.05 + 0.1 * k)
    return text


def test_no_returns_are_the_top_cluster_of_the_ranges(tmp_path, capsys):
    """No-returns that vary by centimetres (12,300 readings from 50.95 to 51.05 m): all of them +Inf, not only
    those at the largest value; the walls below the gap stay."""
    rng = np.random.RandomState(3)
    scans = []
    for k in range(100):
        ranges = list(2.0 + 0.1 * np.arange(57))              # walls 2.0 .. 7.6 m
        ranges += list(np.round(rng.uniform(50.95, 51.05, 123), 2))
        scans.append(ranges)
    log = write(tmp_path, 'c.log', ranges_log(scans))
    out = str(tmp_path / 'c.bag')
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q', '--corrected', 'no'], capsys)
    assert code == 0
    assert ('no-return readings: the top cluster of the ranges, 50.950-51.050 m (12300 readings; 0 in the 0.2 m below '
            'it), +Inf from 50.945 m; 12300 readings written as +Inf') in stdout
    r = np.array([m.ranges for _, m in read_bag(out)['/scan']])
    assert np.all(np.isposinf(r[:, 57:])) and np.all(np.isfinite(r[:, :57]))
    assert np.nanmax(r[np.isfinite(r)]) == pytest.approx(7.6)


def test_far_walls_spread_in_range_are_no_cluster():
    """A long corridor: the far walls spread from 30 to 50.5 m in 1 cm steps, 12 readings at the largest value.
    No gap below the top: no no-return value (the largest value with 10 readings was taken for one)."""
    far = list(np.round(np.arange(30.0, 50.5, 0.01), 2)) + [50.5] * 12
    lasers = [carmen.Laser(1, 'FLASER', np.array(far[i::4]), 0.0, 0.0, None, (0, 0, 0), (0, 0, 0), 1.0)
              for i in range(4)]
    assert carmen.detect_no_return(lasers) is None
    # The same top with a gap below it is a cluster; too few readings, or too many just below it, are not.
    gap = [carmen.Laser(1, 'FLASER', np.r_[np.arange(30.0, 50.0, 0.01), [50.5] * 12], 0.0, 0.0, None, (0, 0, 0),
                        (0, 0, 0), 1.0)]
    assert carmen.detect_no_return(gap) == carmen.NoReturn(50.5, 50.5, 12, 0)
    few = [gap[0]._replace(ranges=np.r_[np.arange(30.0, 50.0, 0.01), [50.5] * 9])]
    assert carmen.detect_no_return(few) is None
    # Walls up to 50.45 m, three readings a centimetre: 45 within 0.2 m below the 12 (12 < 10 x 45), and any lower
    # edge leaves the 12 above its band as more than 1 % strays.
    crowded = [gap[0]._replace(ranges=np.r_[np.repeat(np.arange(49.0, 50.455, 0.01), 3), [50.5] * 12])]
    assert carmen.detect_no_return(crowded) is None


def test_no_returns_are_found_whatever_the_steps_of_the_ranges():
    """Ranges written in 5 cm steps (fhw): the no-returns at 51.05 and 51.10 m are one cluster. Ranges in 1 cm steps
    whose no-returns spread over 51.05-51.12 m, two strays above them at 51.16 m and far walls below in 5 cm steps
    (MIT's infinite corridor): the cluster and the strays are no-returns, the far walls are not."""
    def lasers(ranges):
        return [carmen.Laser(1, 'FLASER', np.asarray(ranges, dtype=float), 0.0, 0.0, None, (0, 0, 0), (0, 0, 0),
                             1.0)]
    walls_5cm = np.round(np.arange(0.5, 44.0, 0.05), 2)
    fhw = np.r_[walls_5cm, [51.05] * 607, [51.10] * 40]
    assert carmen.detect_no_return(lasers(fhw)) == carmen.NoReturn(51.05, 51.10, 647, 0)
    corridor = np.r_[np.round(np.arange(0.5, 50.9, 0.05), 2), [51.05] * 218, [51.06] * 3720, [51.07] * 191,
                     [51.10] * 35, [51.11] * 466, [51.12] * 25, [51.16] * 2]
    c = carmen.detect_no_return(lasers(corridor))
    assert c is not None and c.low == pytest.approx(51.05) and c.high == pytest.approx(51.16) and c.count == 4657
    r = carmen.rep117_ranges(corridor, c.low, np.inf)
    assert np.sum(np.isinf(r)) == 4657 and np.nanmax(r[np.isfinite(r)]) == pytest.approx(50.85)
    # Readings spread out above the band, one at each value: up to 1 % of the cluster they are strays (no-returns
    # too), beyond it the top of the ranges is no cluster.
    spread = np.round(np.arange(51.5, 57.5, 0.1), 1)
    c = carmen.detect_no_return(lasers(np.r_[corridor, spread[:40]]))
    assert c is not None and c.low == pytest.approx(51.05) and c.count == 4657 + 40
    assert carmen.detect_no_return(lasers(np.r_[corridor, spread[:60]])) is None


def test_a_message_quotes_a_long_field_shortened_and_never_cuts_its_own_words(tmp_path):
    text = HEAD + odom_line((0, 0, 0), 1.0) + flaser_line([1.0, 2.5, 3.0], (0, 0, 0), 1.1).replace('2.50', 'x' * 200)
    log = write(tmp_path, 'q.log', text)
    with pytest.raises(cc.ConversionError) as e:
        carmen.parse_log(log)
    message = str(e.value)
    assert "'xxxxx" in message and '(a field of 200 characters)' in message and 'x' * 100 not in message
    long_own_words = 'time stamps that advance (' + 'the seconds from one line to the next, ' * 4 + ')'
    error = cc.ConversionError('a.log', None, 'something', got=long_own_words)
    assert str(error).endswith(' '.join(long_own_words.split()))


def test_param_cap_is_named_and_laser_max_overrides_it(tmp_path, capsys):
    """PARAM robot_front_laser_max 10: readings beyond 10 m are +Inf and the summary names the PARAM and how many;
    --laser-max 20 keeps the 15 m wall, --laser-max none too (only the no-returns are +Inf)."""
    scans = [[2.0] * 170 + [15.0] * 8 + [81.83] * 2 for _ in range(10)]
    log = write(tmp_path, 'p.log', ranges_log(scans, HEAD + 'PARAM robot_front_laser_max 10 nohost 0\n'))
    out = str(tmp_path / 'p.bag')
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q', '--corrected', 'no'], capsys)
    assert code == 0
    assert ('PARAM robot_front_laser_max 10 m capped 80 FLASER readings to +Inf (readings beyond it; --laser-max '
            'overrides)') in stdout
    scan = read_bag(out)['/scan'][0][1]
    assert np.sum(np.isposinf(scan.ranges)) == 10 and scan.range_max == pytest.approx(10.0)
    for option, range_max in (('20', 20.0), ('none', 81.825), ('0', 81.825)):
        code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q', '--corrected', 'no', '--laser-max', option],
                                   capsys)
        assert code == 0 and 'capped' not in stdout and '20 readings written as +Inf' in stdout, option
        scan = read_bag(out)['/scan'][0][1]
        assert list(np.array(scan.ranges)[170:178]) == [15.0] * 8 and np.sum(np.isposinf(scan.ranges)) == 2
        assert scan.range_max == pytest.approx(range_max), option
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q', '--corrected', 'no', '--laser-max', '5'], capsys)
    assert code == 0 and '--laser-max 5 m capped 80 FLASER readings to +Inf (readings beyond it)' in stdout
    with pytest.raises(SystemExit) as e:
        carmen.main([log, '-o', out, '-q', '--laser-max', '-1'])
    err = capsys.readouterr().err
    assert e.value.code == 2 and 'expected metres (a positive number), or none or 0 for no cap' in err


def test_backward_stamps_are_counted_and_made_monotonic(tmp_path, capsys):
    stamps = [1.0, 1.1, 1.5, 1.3, 1.45, 1.6, 1.7]  # 1.5 is late
    text = HEAD + ''.join(odom_line((0.1 * i, 0, 0), t) for i, t in enumerate(stamps))
    log = write(tmp_path, 'b.log', text)
    out = str(tmp_path / 'b.bag')
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q'], capsys)
    assert code == 0
    assert '1 lines have a stamp earlier than the line before' in stdout
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    # The late stamp is pooled with the next one (1.5, 1.3 -> 1.4 s), and the second of the pooled lines is moved
    # 1 us after the first, in file order: every pose is kept, in the log's order.
    xs = [pose2(m)[0] for _, m in bag['/odom']]
    assert xs == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    t = np.array([m.header.stamp.to_sec() for _, m in bag['/odom']])
    assert np.all(np.diff(t) > 0)
    np.testing.assert_allclose(t, [1.0, 1.1, 1.4, 1.4 + 1e-6, 1.45, 1.6, 1.7], atol=1e-9)
    assert '1 timed lines had the stamp of the line before them' in stdout


def test_isotonic_fix_is_minimal():
    fixed = cc.isotonic_increasing([1.0, 2.0, 5.0, 3.0, 4.0, 6.0])
    assert list(fixed) == [1.0, 2.0, 4.0, 4.0, 4.0, 6.0]
    fixed, (steps, late, lag), invalid = cc.fix_stamps([10.0, 11.0, 1e-42, 12.0, 11.5, 13.0])
    assert invalid == 1 and steps == 1 and late == 1 and lag == pytest.approx(0.5)
    assert np.all(np.diff(fixed) >= 0)


def test_plain_and_gzip_give_the_same_bag(tmp_path):
    text, _ = corrected_log()
    a, b = str(tmp_path / 'a.bag'), str(tmp_path / 'b.bag')
    assert carmen.main([write(tmp_path, 'x.log', text), '-o', a, '-q']) == 0
    assert carmen.main([write(tmp_path, 'x.log.gz', text, compress=True), '-o', b, '-q']) == 0
    ba, bb = read_bag(a), read_bag(b)
    assert {k: len(v) for k, v in ba.items()} == {k: len(v) for k, v in bb.items()}
    assert [pose2(m) for _, m in ba['/odom']] == [pose2(m) for _, m in bb['/odom']]


# --- time stamps: garbage rebuilt from the line order, and the file's order kept -------------------


def timed_text(stamps, scan_every=2, turn=0.0):
    """ODOM lines (x = 0.01 per line, heading ``turn`` per line) with a FLASER line after every
    ``scan_every``-th, its pose the raw pose 5 mm on from the ODOM line before it (odometry at the scan's time);
    ``stamps``: the stamp text of each timed line in file order."""
    text, k, pose = HEAD, 0, (0.0, 0.0, 0.0)
    for n, ts in enumerate(stamps):
        if scan_every and n % (scan_every + 1) == scan_every:
            r = ' '.join(['2.00'] * 180)
            p = '%.6f %.6f %.6f' % (pose[0] + 0.005, pose[1], pose[2])
            text += 'FLASER 180 %s %s %s %s pippo %s\n' % (r, p, p, ts, ts)
        else:
            pose = (0.01 * k, 0.0, turn * k)
            text += 'ODOM %.6f 0 %.6f 0 0 0 %s pippo %s\n' % (pose[0], pose[2], ts, ts)
            k += 1
    return text


def header_stamps(bag, topic):
    return np.array([(m.header.stamp if hasattr(m, 'header') else m.transforms[0].header.stamp).to_sec()
                     for _, m in bag[topic]])


def odom_at(bag, stamps):
    """The odometry a consumer reads at each stamp: linear between the two /odom samples around it (heading the
    short way), the sample itself at its own stamp."""
    t = header_stamps(bag, '/odom')
    p = np.array([pose2(m) for _, m in bag['/odom']])
    out = []
    for s in stamps:
        j = int(np.searchsorted(t, s, side='right'))
        if t[j - 1] == s or j == len(t):
            out.append(p[j - 1])
            continue
        a = (s - t[j - 1]) / (t[j] - t[j - 1])
        dth = float(cc.wrap_angle(p[j, 2] - p[j - 1, 2]))
        out.append((p[j - 1, 0] + a * (p[j, 0] - p[j - 1, 0]), p[j - 1, 1] + a * (p[j, 1] - p[j - 1, 1]),
                    p[j - 1, 2] + a * dth))
    return np.array(out)


def log_pairing(path):
    """The raw odometry pose of the ODOM line before each laser line, as the log pairs them: the raw chain
    rebuilt across the resets, a reset line standing for the raw pose before it."""
    log = carmen.parse_log(path)
    resets = set(carmen.find_resets(log.records)[0])
    odom_idx = [i for i, r in enumerate(log.records) if isinstance(r, carmen.Odom)]
    raw = iter(carmen.rebuild_raw_odometry([(log.records[i].x, log.records[i].y, log.records[i].theta)
                                            for i in odom_idx], [i in resets for i in odom_idx]))
    pairs, last = [], None
    for i, r in enumerate(log.records):
        if isinstance(r, carmen.Odom) and i not in resets:
            last = next(raw)
        elif isinstance(r, carmen.Laser):
            pairs.append(last)
    return np.array(pairs)


def test_stamps_past_ros_time_are_rebuilt_from_the_line_order(tmp_path, capsys):
    """The MIT infinite-corridor layout: after the 4th scan every stamp is the text 4.29497e+09 (past 2^32 s,
    which ROS time cannot hold): the stamps go on at the log's own seconds per line."""
    n_good, n = 12, 60  # 12 timed lines (8 ODOM, 4 scans) with true stamps, 0.1 s apart
    stamps = ['%.1f' % (100.0 + 0.1 * k) for k in range(n_good)] + ['4.29497e+09'] * (n - n_good)
    log = write(tmp_path, 'mit.log', timed_text(stamps))
    out = str(tmp_path / 'mit.bag')
    code, stdout, err = run_main(carmen.main, [log, '-o', out, '-q'], capsys)
    assert code == 0, err
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    scans = header_stamps(bag, '/scan')
    assert len(scans) == n // 3 and scans.max() < 2 ** 32
    np.testing.assert_allclose(scans, 100.0 + 0.1 * np.arange(2, n, 3), atol=1e-5)
    first_rebuilt = 2 + n_good + 1  # two header lines, then the 13th timed line
    assert ('time stamps rebuilt from the line order: 48 of 60 timed lines (ODOM, laser and TRUEPOS lines; resets '
            'do not count) had garbage stamps, from line %d (stamp 4294970000) on, the last at line %d: 48 at or '
            'past 2^32 s' % (first_rebuilt, n + 2)) in stdout
    assert 'after the last trustworthy stamp extrapolated at 0.1 s per line (measured on the 12 trustworthy stamps)' \
        in stdout


def test_garbage_stamps_are_interpolated_between_trustworthy_ones(tmp_path):
    """Stamps 0, a denormal, a stamp 2 h ahead, a run stuck at one value while the log goes on, a stretch an
    hour behind: each rebuilt by line number between the trustworthy stamps around it."""
    true = 5000.0 + 0.1 * np.arange(400)
    logged = true.copy()
    logged[5:8] = 0.0                 # not positive
    logged[12] = 1e-42                # far below its neighbours
    logged[20] = true[20] + 7200.0    # far above them
    logged[100:250] = true[99]        # stuck: the clock stops, the lines go on
    logged[300:330] = true[300:330] - 3600.0  # a stretch an hour behind (longer than the neighbourhood)
    log = carmen.parse_log(write(tmp_path, 'g.log', timed_text(['%.10g' % t for t in logged], scan_every=0)))
    conv = carmen.Conversion(log)
    np.testing.assert_allclose(conv.odom_stamps_all, true, atol=1e-4)
    note = next(n for n in conv.notes if n.startswith('time stamps rebuilt'))
    assert '185 of 400 timed lines' in note and 'from line 8 (stamp 0) on, the last at line 332' in note
    assert ('3 0 or negative; 150 stuck at one value while the log goes on; 2 far from the median of the lines '
            'around them; 30 on a stretch that jumps away from the rest of the log') in note
    assert 'extrapolated' not in note  # first and last stamps trustworthy: nothing to extrapolate


def test_repair_stamps_picks_the_story_most_lines_tell():
    """Stretches of garbage longer than the neighbourhood, at the start or in the middle, up or down."""
    real = 100.0 + np.arange(200.0)
    up, down = np.full(30, 1e6) + np.arange(30.0), 0.001 * np.arange(30.0) + 0.5
    # (Stamps far below the rest at the very start are a log starting early and then pausing, as far as the
    # stamps tell: a pause shorter than JUMP_LINES line periods is no jump.)
    for garbage, at in ((up, 0), (up, 80), (down, 80)):
        stamps = np.concatenate([real[:at], garbage, real[at:]])
        r = cc.repair_stamps(stamps)
        assert r.rebuilt.tolist() == list(range(at, at + 30))
        assert np.all(np.diff(r.stamps) > 0)
        lines_real = np.r_[np.arange(at), np.arange(at + 30, 230)]
        np.testing.assert_allclose(r.stamps[lines_real], real)
        if at:
            np.testing.assert_allclose(r.stamps[at:at + 30], np.linspace(real[at - 1], real[at], 32)[1:-1])
        else:  # before the first trustworthy stamp: extrapolated at its seconds per line
            assert r.line_period == pytest.approx(1.0)
            np.testing.assert_allclose(r.stamps[:30], 100.0 - np.arange(30, 0, -1))
    with pytest.raises(cc.TooFewStamps, match='every stamp 0'):
        cc.repair_stamps([0.0] * 5)
    with pytest.raises(cc.TooFewStamps, match='every stamp 7'):
        cc.repair_stamps([7.0] * 5)
    r = cc.repair_stamps([7.0] * 5, line_period=0.5)
    assert r.stamps.tolist() == [7.0, 7.5, 8.0, 8.5, 9.0] and r.period_given
    r = cc.repair_stamps([0.0] * 3, line_period=0.5)
    assert r.stamps.tolist() == [cc.REBUILT_START, cc.REBUILT_START + 0.5, cc.REBUILT_START + 1.0]


def test_line_period_and_stamps_from_the_lines(tmp_path, capsys):
    jitter = [1.0, 1.13, 1.18, 1.31, 1.42, 1.48, 1.61, 1.69, 1.83, 1.9]
    log = write(tmp_path, 'j.log', timed_text(['%g' % t for t in jitter], scan_every=0))
    out = str(tmp_path / 'j.bag')
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q', '--stamps', 'lines'], capsys)
    assert code == 0
    np.testing.assert_allclose(header_stamps(read_bag(out), '/odom'), 1.0 + 0.1 * np.arange(10), atol=1e-9)
    assert ('time stamps rebuilt from the line order on request (--stamps lines): 9 of 10 timed lines (ODOM, laser '
            'and TRUEPOS lines; resets do not count) evenly spaced from the first trustworthy stamp (line 3, 1 s) at '
            '0.1 s per line (measured on the 10 trustworthy stamps)') in stdout
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q', '--stamps', 'lines', '--line-period', '0.25'],
                               capsys)
    assert code == 0 and 'at 0.25 s per line (given by --line-period)' in stdout
    np.testing.assert_allclose(header_stamps(read_bag(out), '/odom'), 1.0 + 0.25 * np.arange(10), atol=1e-9)


def flaser_text(poses, stamp_texts, n=361):
    r = ' '.join('%.2f' % (2.0 + 0.01 * i) for i in range(n))
    return ''.join('FLASER %d %s %.4f %.4f %.4f %.4f %.4f %.4f %s nohost %s\n' % ((n, r) + tuple(p) + tuple(p) + (t, t))
                   for p, t in zip(poses, stamp_texts))


def _convert(capsys, log, out, *options):
    """Converts @log to @out with the options; asserts it succeeded. Returns (stdout, the bag's messages)."""
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q'] + list(options), capsys)
    assert code == 0
    return stdout, read_bag(out)


def test_log_without_odometry_or_stamps_is_refused(tmp_path, capsys):
    """The orebro layout: FLASER lines only, every stamp 0. Neither odometry nor times can be had from it
    without being told: one error naming both, and the options that resolve them."""
    poses = [(0.1 * k, 0.02 * k, 0.01 * k) for k in range(8)]
    text = '# orebro layout\n' + flaser_text(poses, ['0'] * 8)
    err = _expect_error(tmp_path, capsys, text, 'bad.log: expected raw odometry: ODOM lines (--laser-poses odometry '
                        'if the laser lines\' poses are raw odometry; --no-odometry to write none) and time stamps '
                        'that advance (--line-period S: the seconds from one line to the next), got no ODOM line '
                        '(8 FLASER); every stamp 0')
    assert err.count('\n') == 1
    log = str(tmp_path / 'bad.log')
    out = str(tmp_path / 'o.bag')
    stdout, bag = _convert(capsys, log, out, '--laser-poses', 'odometry', '--line-period', '0.2')
    np.testing.assert_allclose([pose2(m) for _, m in bag['/odom']], poses, atol=1e-6)
    np.testing.assert_allclose(header_stamps(bag, '/scan'), cc.REBUILT_START + 0.2 * np.arange(8), atol=1e-9)
    assert '8 0 or negative; spaced from 1 s (the log has no trustworthy stamp) at 0.2 s per line (given by ' \
        '--line-period)' in stdout
    _, bag = _convert(capsys, log, out, '--no-odometry', '--line-period', '0.2')
    assert '/odom' not in bag and len(bag['/scan']) == 8 and len(bag['/ground_truth/odom']) == 8


def repeat_log(order='after', digits=6, n=12):
    """A log whose ODOM lines repeat the robot pose of the laser line next to them (``order`` 'after': the laser
    line first, as a corrected log whose ODOM lines are corrected poses; 'before': the laser line copies the ODOM
    line before it), the robot driving an arc; the ODOM lines written with ``digits`` decimals, the stamps all
    real. Returns (text, the laser poses)."""
    poses = [(0.2 * k, 0.01 * k * k, 0.05 * k) for k in range(n)]
    text = HEAD
    for k, p in enumerate(poses):
        laser = flaser_line([2.0] * 180, p, 1.0 + 0.2 * k)
        odom = 'ODOM %.*f %.*f %.*f 0 0 0 %.3f pippo %.3f\n' % (digits, p[0], digits, p[1], digits, p[2],
                                                               1.05 + 0.2 * k, 1.05 + 0.2 * k)
        text += laser + odom if order == 'after' else odom + laser
    return text, poses


@pytest.mark.parametrize('order, digits', [('after', 6), ('after', 3), ('before', 6)])
def test_odom_lines_that_repeat_the_laser_poses_are_refused(tmp_path, capsys, order, digits):
    """ODOM lines that repeat the laser lines' poses are no raw odometry the converter can trust, whatever their
    stamps: converted, /odom would be the laser poses (one scan late where the ODOM line follows its laser line).
    Refused, naming the options; each option converts as it says."""
    text, poses = repeat_log(order, digits)
    # Every ODOM line but the first is next to a laser line while the robot moves, and repeats its pose.
    err = _expect_error(tmp_path, capsys, text, "bad.log: expected raw odometry: ODOM lines that do not repeat the "
                        "poses of the laser lines next to them (within 0.001 m and 0.0001 rad, while the robot moves; "
                        "--corrected no if they are raw odometry all the same, the laser lines copying their poses; "
                        "--laser-poses odometry to take the laser lines' poses as odometry, knowingly; --no-odometry "
                        "to write none), got ODOM lines that repeat the laser poses (11 of 11 next to a laser line)")
    assert err.count('\n') == 1
    log = str(tmp_path / 'bad.log')
    out = str(tmp_path / 'o.bag')
    _, bag = _convert(capsys, log, out, '--no-odometry')
    assert '/odom' not in bag and len(bag['/scan']) == 12
    np.testing.assert_allclose([pose2(m) for _, m in bag['/ground_truth/odom']], poses, atol=1e-6)
    stdout, bag = _convert(capsys, log, out, '--laser-poses', 'odometry')
    assert 'odometry from the robot poses of the laser lines (--laser-poses odometry)' in stdout
    np.testing.assert_allclose([pose2(m) for _, m in bag['/odom']], poses, atol=1e-6)
    _, bag = _convert(capsys, log, out, '--corrected', 'no')
    odom = np.array([pose2(m) for _, m in bag['/odom']])
    assert len(odom) == 12 + (11 if order == 'after' else 12)  # the ODOM lines, and a sample at each scan after one
    np.testing.assert_allclose(odom[:2], [poses[0]] * 2, atol=1e-3)  # the ODOM line, the scan after it


def test_repeats_are_told_from_resets_and_a_robot_standing_still(tmp_path):
    """The resets of a corrected log repeat the laser poses too, but the ODOM lines between them are raw: no
    repeats among them. Taken for raw lines, the resets are half the ODOM lines next to a laser line: not most.
    A robot standing still repeats every pose: no motion, nothing counted."""
    records = carmen.parse_log(write(tmp_path, 'c.log', corrected_log()[0])).records
    resets, _ = carmen.find_resets(records)
    assert carmen.find_repeats(records, resets) == (0, 3)
    assert carmen.find_repeats(records) == (3, 6)
    still = [carmen.Odom(1, 0.0, 0.0, 0.0, 0, 0, 1.0)]
    for k in range(10):
        still += [carmen.Laser(2, 'FLASER', np.ones(3), 0.0, 0.0, None, (0, 0, 0), (0, 0, 0), 1.0 + k),
                  carmen.Odom(3, 0.0, 0.0, 0.0, 0, 0, 1.1 + k)]
    assert carmen.find_repeats(still) == (0, 0)


def test_log_at_one_stamp_is_refused(tmp_path, capsys):
    """The belgioioso layout: every line at one stamp. Refused, naming --line-period; with it, the lines are
    spread at that period from the log's stamp."""
    stamps = ['1199958306.5'] * 40
    _expect_error(tmp_path, capsys, timed_text(stamps, scan_every=1), 'bad.log: expected time stamps that advance '
                  '(--line-period S: the seconds from one line to the next), got every stamp 1199958306.5')
    out = str(tmp_path / 'o.bag')
    code, stdout, _ = run_main(carmen.main, [str(tmp_path / 'bad.log'), '-o', out, '-q', '--line-period', '0.1'],
                               capsys)
    assert code == 0
    bag = read_bag(out)
    assert len(bag['/odom']) == 20 + 20  # the ODOM lines, and a sample at each scan
    np.testing.assert_allclose(header_stamps(bag, '/scan'), 1199958306.5 + 0.1 * np.arange(1, 40, 2), atol=1e-6)
    assert '39 all equal: the stamps do not advance' in stdout


def test_scan_odometry_is_the_pose_of_the_odom_line_before_it(tmp_path, capsys):
    """Stamps backwards and equal around the scans: the odometry read at a scan's stamp (interpolated from /odom
    between the samples around it) is the raw pose of the ODOM line before the scan in the file, as the log
    pairs them, not a later ODOM line's that the fitted stamps would put at the same time."""
    # timed lines in file order, the robot turning 0.3 rad per ODOM line; every 3rd line a scan
    stamps = ['1.0', '1.1', '1.1',      # a scan at the stamp of the ODOM line before it
              '1.3', '1.2', '1.15',     # ODOM lines going back; the scan earlier than both
              '1.25', '1.4', '1.4',     # the scan shares the stamp of the ODOM line before it
              '1.35', '1.36', '1.5',
              '1.55', '1.6', '1.58']    # the scan earlier than the ODOM line before it
    log = write(tmp_path, 'p.log', timed_text(stamps, scan_every=2, turn=0.3))
    out = str(tmp_path / 'p.bag')
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q'], capsys)
    assert code == 0
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    expected = log_pairing(log)
    got = odom_at(bag, header_stamps(bag, '/scan'))
    assert len(got) == 5
    np.testing.assert_allclose(got[:, :2], expected[:, :2], atol=1e-9)
    np.testing.assert_allclose(cc.wrap_angle(got[:, 2] - expected[:, 2]), 0.0, atol=1e-9)
    assert '5 odometry samples added at the stamps of the scans' in stdout
    # The stamps of the timed lines follow the file order, strictly.
    o, sc = header_stamps(bag, '/odom'), header_stamps(bag, '/scan')
    raw_odom = np.setdiff1d(o, sc)
    order = np.argsort(np.r_[raw_odom, sc], kind='stable')
    assert list(order) == [0, 1, 10, 2, 3, 11, 4, 5, 12, 6, 7, 13, 8, 9, 14]


def test_odometry_gaps_with_motion_are_reported(tmp_path, capsys):
    """3.1 s without ODOM lines while the true poses (TRUEPOS) turn by 80 degrees: reported with the lines around
    the gap, its duration and the motion; a gap while the robot stands still is only counted."""
    text, t, th, line = HEAD, 1.0, 0.0, 2
    odom_lines = []
    for phase, n in (('odom', 10), ('turn', 30), ('odom', 10), ('stand', 20), ('odom', 10)):
        for _ in range(n):
            if phase == 'odom':
                text += 'ODOM 0 0 %.6f 0 0 0 %.3f pippo %.3f\n' % (th, t, t)
                line += 1
                odom_lines.append(line)
            if phase == 'turn':
                th += math.radians(80.0) / n
            text += 'TRUEPOS 0 0 %.6f 0 0 0 %.3f pippo %.3f\n' % (th, t, t)
            line += 1
            t += 0.1
    log = write(tmp_path, 'gap.log', text)
    out = str(tmp_path / 'gap.bag')
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q'], capsys)
    assert code == 0
    assert ('odometry gaps: 1 places where two consecutive ODOM lines (resets aside) are more than 1 s apart '
            '(--odom-gap) while the robot moves') in stdout
    assert 'the longest 3.10 s; 1 more such gaps show no motion' in stdout
    assert ('odometry gap, lines %d-%d: 3.10 s without ODOM; reference moves 0.00 m and turns 80 deg; odometry jumps '
            '0.00 m and 80 deg' % (odom_lines[9], odom_lines[10])) in stdout
    code, stdout, _ = run_main(carmen.main, [log, '-o', out, '-q', '--odom-gap', '5'], capsys)
    assert code == 0 and 'odometry gap' not in stdout


def test_odometry_gap_seen_in_the_scans(tmp_path, capsys):
    """No reference and no jump in the odometry, but the scans in the gap change: reported."""
    text, t = HEAD, 1.0
    for k in range(30):
        if k < 10 or k >= 25:
            text += odom_line((0.0, 0.0, 0.0), t)
        else:  # 15 scans without ODOM lines between them, the walls moving away by 0.05 m per scan
            text += flaser_line([2.0 + 0.05 * (k - 10)] * 180, (0.0, 0.0, 0.0), t)
        t += 0.1
    out = str(tmp_path / 's.bag')
    code, stdout, _ = run_main(carmen.main, [write(tmp_path, 's.log', text), '-o', out, '-q', '--no-return', 'none'],
                               capsys)
    assert code == 0
    assert ('odometry gap, lines 12-28: 1.60 s without ODOM; odometry moves 0.00 m and 0 deg; 15 scans in between, '
            'ranges change by 0.70 m (median)') in stdout


# --- malformed inputs: the promised error, and no bag ----------------------------------------------


def _expect_error(tmp_path, capsys, text, pattern, name='bad.log', compress=False, raw=None):
    if raw is not None:
        path = tmp_path / name
        path.write_bytes(raw)
        log = str(path)
    else:
        log = write(tmp_path, name, text, compress)
    out = tmp_path / 'out.bag'
    code, _, err = run_main(carmen.main, [log, '-o', str(out), '-q'], capsys)
    assert code == 1
    assert pattern in err, err
    assert not out.exists()
    assert not [f for f in os.listdir(str(tmp_path)) if f.endswith('.bag')], 'a partial bag was left behind'
    return err


def test_truncated_laser_line(tmp_path, capsys):
    text, _ = corrected_log()
    lines = text.splitlines(True)
    i = next(k for k, l in enumerate(lines) if l.startswith('FLASER'))
    lines[i] = ' '.join(lines[i].split()[:100]) + '\n'
    err = _expect_error(tmp_path, capsys, ''.join(lines), 'bad.log:%d: expected FLASER n, 180 readings' % (i + 1))
    assert 'got 100 fields' in err


def test_text_in_a_number_field(tmp_path, capsys):
    text = HEAD + odom_line((0, 0, 0), 1.0) + 'ODOM 0.1 abc 0 0 0 0 1.1 pippo 1.1\n'
    _expect_error(tmp_path, capsys, text, "bad.log:4: expected numbers in the ODOM fields")


def test_empty_file(tmp_path, capsys):
    _expect_error(tmp_path, capsys, '', 'bad.log: expected CARMEN log lines (ODOM, FLASER, ...), got an empty file')


def test_truncated_gzip(tmp_path, capsys):
    text, _ = corrected_log()
    whole = gzip.compress((text * 20).encode())
    _expect_error(tmp_path, capsys, None, 'expected more data (the compressed file is cut short or damaged)',
                  name='cut.log.gz', raw=whole[:len(whole) // 2])


def test_skip_bad_counts_and_reports(tmp_path, capsys):
    text, expected = corrected_log()
    text += 'ODOM 1 2\nODOM x 0 0 0 0 0 9 pippo 9\n'
    out = str(tmp_path / 's.bag')
    code, stdout, _ = run_main(carmen.main, [write(tmp_path, 's.log', text), '-o', out, '-q', '--skip-bad'], capsys)
    assert code == 0
    assert 'malformed lines skipped (--skip-bad): 2' in stdout
    assert 's.log:%d: expected ODOM x y theta' % (len(text.splitlines()) - 1) in stdout
    assert len(read_bag(out)['/odom']) == len(expected) + 3  # and one sample at each of the 3 scans


def test_interrupt_leaves_no_bag(tmp_path, capsys, monkeypatch):
    text, _ = corrected_log()
    log = write(tmp_path, 'i.log', text)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    from rbpf_slam import convert_msgs
    monkeypatch.setattr(convert_msgs, 'laser_scan', interrupted)  # Ctrl-C in the middle of writing
    code, _, err = run_main(carmen.main, [log, '-o', str(tmp_path / 'i.bag'), '-q'], capsys)
    assert code == 130 and 'interrupted' in err
    assert not [f for f in os.listdir(str(tmp_path)) if f.endswith('.bag')]


# --- the real logs ---------------------------------------------------------------------------------


@pytest.fixture(scope='module')
def intel(tmp_path_factory):
    log = data_path('carmen', 'intel-corrected.log.gz')
    out = str(tmp_path_factory.mktemp('intel') / 'intel.bag')
    summary = cc.convert_to_bag(carmen.convert, carmen.build_parser().parse_args([log, '-o', out]))
    return log, out, summary


def test_intel_counts_stamps_and_quirks(intel):
    log, out, summary = intel
    text = summary.text()
    # 14541 ODOM lines: 910 resets (69 with garbage stamps) and 13631 raw lines, each one odometry sample
    # (lines logged with one stamp, and stamps pooled by the fit, are moved 1 us apart), and one sample at
    # each of the 910 scans holding the pose of the ODOM line before it.
    assert summary.counts['/odom'] == 13631 + 910 and summary.counts['/tf'] == 13631 + 910
    assert summary.counts['/scan'] == 910 and summary.counts['/ground_truth/odom'] == 910
    assert summary.counts['/ground_truth/path'] == 1 and summary.counts['/tf_static'] == 1
    assert '910 ODOM lines repeat the corrected pose' in text and '69 of them with a time stamp other than 0' in text
    assert '629 lines have a stamp earlier than the line before' in text
    assert ('no-return readings: the top cluster of the ranges, 81.830-81.830 m (4172 readings; 0 in the 0.2 m below '
            'it), +Inf from 81.825 m; 4172 readings written as +Inf') in text
    assert 'rebuilt from the line order' not in text  # no garbage stamps among the timed lines
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    scans = [m for _, m in bag['/scan']]
    r = np.array([s.ranges for s in scans])
    assert np.sum(np.isposinf(r)) == 4172 and np.nanmax(r[np.isfinite(r)]) < 81.83
    assert len(scans[0].ranges) == 180 and scans[0].ranges[0] == pytest.approx(1.09)
    assert scans[0].header.stamp.to_sec() == pytest.approx(32.9068, abs=0.3)
    assert frames_of(bag, '/scan') == {'laser'} and frames_of(bag, '/odom') == {'odom'}
    assert bag['/odom'][0][1].child_frame_id == 'base_link'
    first_ref = pose2(bag['/ground_truth/odom'][0][1])
    assert first_ref == pytest.approx((0.600266, -0.0320327, -0.354665), abs=1e-6)
    path = bag['/ground_truth/path'][0][1]
    assert len(path.poses) == 910 and path.header.frame_id == 'map'


def test_intel_rebuilt_heading_steps_are_whole_encoder_steps():
    log = carmen.parse_log(data_path('carmen', 'intel-corrected.log.gz'))
    conv = carmen.Conversion(log)
    # Its ODOM lines are raw odometry: the resets aside, none of the 910 next to a laser line repeats its pose.
    assert (conv.n_repeats, conv.n_repeat_pairs) == (0, 910)
    d = cc.wrap_angle(np.diff(conv.raw_odom_all[:, 2]))
    k = d[d != 0] / 0.0061455
    whole = np.mean(np.abs(k - np.round(k)) < 0.05)
    assert whole > 0.99, 'only %.1f %% whole encoder steps: the correction leaks in' % (100 * whole)
    # ODOM as logged (the corrected chain) has far fewer
    logged = np.array([r.theta for r in log.odom])
    dn = cc.wrap_angle(np.diff(logged))
    kn = dn[dn != 0] / 0.0061455
    assert np.mean(np.abs(kn - np.round(kn)) < 0.05) < 0.95


def test_aces_whole_log(tmp_path):
    log = data_path('carmen', 'aces-corrected.log.gz')
    out = str(tmp_path / 'aces.bag')
    summary = cc.convert_to_bag(carmen.convert, carmen.build_parser().parse_args([log, '-o', out]))
    assert summary.counts['/odom'] == 7374 + 440 and summary.counts['/scan'] == 440  # + a sample at each scan
    assert summary.counts['/ground_truth/odom'] == 440
    conv = carmen.Conversion(carmen.parse_log(log))
    assert (conv.n_repeats, conv.n_repeat_pairs) == (0, 440)  # raw ODOM lines, the resets aside
    # The top cluster is 50.0 m alone: the next readings (49.91, 49.86, 49.81 m) lie beyond a 2 cm step.
    assert ('no-return readings: the top cluster of the ranges, 50.000-50.000 m (620 readings; 3 in the 0.2 m below '
            'it), +Inf from 49.995 m; 620 readings written as +Inf') in summary.text()
    assert 'going backwards' not in summary.text()
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    r = np.array([m.ranges for _, m in bag['/scan']])
    assert np.sum(np.isposinf(r)) == 620 and np.max(r[np.isfinite(r)]) == pytest.approx(49.91, abs=0.01)
    assert bag['/odom'][0][0] == pytest.approx(0.110201, abs=1e-6)
    assert bag['/odom'][-1][0] == pytest.approx(1365.63, abs=1e-3)


def test_csail_robotlaser_log(tmp_path, capsys):
    log = data_path('freiburg_course', 'csail.log')
    out = str(tmp_path / 'csail.bag')
    # No ODOM lines, so no raw odometry: refused unless an option says what the laser poses are.
    code, _, err = run_main(carmen.main, [log, '-o', out, '-q'], capsys)
    assert code == 1 and not os.path.exists(out)
    assert 'expected raw odometry' in err and '--laser-poses odometry' in err and '--no-odometry' in err
    assert 'got no ODOM line (686 ROBOTLASER1)' in err
    # Its laser poses are corrected ones (an offline SLAM result): scans 4 and 665, taken where the robot came
    # back after a 380 m loop, overlap within a few cm as placed by them (below). So they are the reference,
    # and the bag has no odometry.
    summary = cc.convert_to_bag(carmen.convert, carmen.build_parser().parse_args([log, '-o', out, '--no-odometry']))
    assert summary.counts['/scan'] == 686 and summary.counts['/ground_truth/odom'] == 686
    assert '/odom' not in summary.counts and '/tf' not in summary.counts
    assert 'no odometry written (--no-odometry)' in summary.text()
    bag = read_bag(out)

    def points(k):  # scan k in the map frame, placed at its reference pose (laser pose = robot pose here)
        scan, (x, y, th) = bag['/scan'][k][1], pose2(bag['/ground_truth/odom'][k][1])
        r = np.array(scan.ranges)
        a = th + scan.angle_min + scan.angle_increment * np.arange(len(r))
        ok = np.isfinite(r) & (r < 20.0)
        return np.column_stack([x + r[ok] * np.cos(a[ok]), y + r[ok] * np.sin(a[ok])])
    p, q = points(4), points(665)
    nearest = np.sqrt(np.min(np.sum((q[:, None, :] - p[None, :, :]) ** 2, axis=2), axis=1))
    assert np.median(nearest) < 0.05  # raw odometry after 380 m would be off by metres
    s = bag['/scan'][0][1]
    assert len(s.ranges) == 361 and s.angle_min == pytest.approx(-math.pi / 2, abs=1e-6)
    assert s.angle_increment == pytest.approx(0.008727, abs=1e-6) and s.range_max == pytest.approx(80.0)
    r = np.array([m.ranges for _, m in bag['/scan']])
    assert np.sum(np.isposinf(r)) == 6097
    assert bag['/scan'][0][0] == pytest.approx(1134864642.914187, abs=1e-5)


def test_limit_reads_the_first_lines(tmp_path):
    log = data_path('carmen', 'intel-corrected.log.gz')
    out = str(tmp_path / 'part.bag')
    summary = cc.convert_to_bag(carmen.convert, carmen.build_parser().parse_args([log, '-o', out, '--limit', '200']))
    assert summary.counts['/scan'] == 3


def test_intel_scan_odometry_follows_the_log_pairing(intel):
    """On the Intel log, the odometry read at each scan's stamp is the raw pose of the ODOM line before the scan:
    no scan-to-scan increment differs from the log's by more than 5 degrees (149 of 909 did when the re-timed
    stamps let a later ODOM line's pose be read at a scan)."""
    log, out, _ = intel
    expected = log_pairing(log)
    bag = read_bag(out)
    got = odom_at(bag, header_stamps(bag, '/scan'))
    assert len(got) == len(expected) == 910

    def increments(p):
        return np.array([cc.se2_between(p[i], p[i + 1]) for i in range(len(p) - 1)])
    d = increments(got) - increments(expected)
    assert int(np.sum(np.degrees(np.abs(cc.wrap_angle(d[:, 2]))) > 5.0)) == 0
    assert np.max(np.abs(d[:, :2])) < 1e-6 and np.max(np.abs(cc.wrap_angle(d[:, 2]))) < 1e-6
