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
    assert len(odom) == len(expected)
    np.testing.assert_allclose(np.array(odom), np.array(expected), atol=2e-6)
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
    # the late stamp was pooled with the next one (same stamp): the later, cumulative pose is kept
    xs = [pose2(m)[0] for _, m in bag['/odom']]
    assert xs == pytest.approx([0.0, 0.1, 0.3, 0.4, 0.5, 0.6])


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
    assert len(read_bag(out)['/odom']) == len(expected)


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
    # 14541 ODOM lines: 910 resets (69 with garbage stamps) and 13631 raw lines, of which 3754 share a
    # stamp with the next one (bursts logged with one stamp, and stamps pooled by the fix).
    assert summary.counts['/odom'] == 9877 and summary.counts['/tf'] == 9877
    assert summary.counts['/scan'] == 910 and summary.counts['/ground_truth/odom'] == 910
    assert summary.counts['/ground_truth/path'] == 1 and summary.counts['/tf_static'] == 1
    assert '910 ODOM lines repeat the corrected pose' in text and '69 of them with a time stamp other than 0' in text
    assert '629 lines have a stamp earlier than the line before' in text
    assert 'no-return value 81.830 m (4172 readings)' in text
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
    assert summary.counts['/odom'] == 7374 and summary.counts['/scan'] == 440
    assert summary.counts['/ground_truth/odom'] == 440
    assert 'no-return value 50.000 m (620 readings)' in summary.text()
    assert 'going backwards' not in summary.text()
    bag = read_bag(out)
    assert_stamps_monotonic(bag)
    r = np.array([m.ranges for _, m in bag['/scan']])
    assert np.sum(np.isposinf(r)) == 620 and np.max(r[np.isfinite(r)]) == pytest.approx(49.91, abs=0.01)
    assert bag['/odom'][0][0] == pytest.approx(0.110201, abs=1e-6)
    assert bag['/odom'][-1][0] == pytest.approx(1365.63, abs=1e-3)


def test_csail_robotlaser_log(tmp_path):
    log = data_path('freiburg_course', 'csail.log')
    out = str(tmp_path / 'csail.bag')
    summary = cc.convert_to_bag(carmen.convert, carmen.build_parser().parse_args([log, '-o', out]))
    assert summary.counts['/scan'] == 686 and summary.counts['/ground_truth/odom'] == 686
    assert '/odom' not in summary.counts  # no ODOM lines: the laser poses are a reference, not odometry
    bag = read_bag(out)
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
