"""rbpf_slam.grid_buildings_benchmark (scripts/grid_buildings_benchmark): a small building's CARMEN log converted,
run over seeds with the built slam_bag, a peer run from its own build script on the log written from the bag,
everything scored; the harness's log from a bag; its arguments."""
import json
import math
import os

import pytest

from rbpf_slam import convert_common as cc
from rbpf_slam import grid_buildings_benchmark as gbb

pytest.importorskip('rosbag')

ROOM = (-2.0, 4.0, -1.5, 2.5)  # x0, x1, y0, y1 [m]: the walls of a rectangular room


def room_ranges(pose, n=180):
    """The ranges of a FLASER scan (from -90 deg over 180 deg, n beams) from a laser at pose in ROOM."""
    x0, x1, y0, y1 = ROOM
    ranges = []
    for k in range(n):
        a = pose[2] - math.pi / 2 + k * math.pi / n
        c, s = math.cos(a), math.sin(a)
        hits = []
        if abs(c) > 1e-9:
            hits += [(x - pose[0]) / c for x in (x0, x1)]
        if abs(s) > 1e-9:
            hits += [(y - pose[1]) / s for y in (y0, y1)]
        ranges.append(min(h for h in hits if h > 0))
    return ranges


def corrected_room_log(scans=40):
    """A corrected log (the Radish layout: each laser line holds the reference pose, the ODOM line after it resets
    to it) of a robot driving a loop in ROOM; its raw odometry turns 2 % too much. Some readings are no returns at
    81.91 m."""
    text = '# CARMEN Logfile\nPARAM robot_frontlaser_offset 0.0 nohost 0\n'
    true, odom, ts = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 1.0
    text += 'ODOM %.6f %.6f %.6f 0 0 0 %.6f h %.6f\n' % (odom + (ts, ts))
    for k in range(scans):
        step = (0.15, 0.0, 2.0 * math.pi / scans)
        true = cc.se2_compose(true, step)
        logged = cc.se2_compose(odom, (step[0], 0.0, step[2] * 1.02))
        ts += 0.5
        text += 'ODOM %.6f %.6f %.6f 0 0 0 %.6f h %.6f\n' % (logged + (ts, ts))
        ranges = room_ranges(true)
        if k % 5 == 0:
            ranges[88:93] = [81.91] * 5
        r = ' '.join('%.3f' % v for v in ranges)
        p = '%.6f %.6f %.6f' % true
        text += 'FLASER %d %s %s %s %.6f h %.6f\n' % (len(ranges), r, p, p, ts, ts)
        text += 'ODOM %s 0 0 0 0 h 0\n' % p  # the reset to the corrected pose
        odom = true
    return text


FAKE_BUILD = r'''#!/bin/bash
# A stand-in for GMapping's build: its "harness" answers with the odometry of each FLASER line and keeps its
# arguments.
set -eu
out=$1
mkdir -p "$out"
cat > "$out/gmap_harness" <<'EOF'
#!/bin/bash
log=$1; prefix=$2; shift 2
echo "$@" > "$prefix.args"
awk '$1=="FLASER"{n=$2; print $(n+9), $(n+6), $(n+7), $(n+8)}' "$log" > "${prefix}_best_history.tum"
cp "${prefix}_best_history.tum" "$prefix.tum"
echo "gmap_harness: done"
EOF
chmod +x "$out/gmap_harness"
'''


def _peer(tmp_path):
    peer = tmp_path / 'peer'
    peer.mkdir()
    (peer / 'build.sh').write_text(FAKE_BUILD)
    return str(peer)


def test_names_and_pairs():
    assert gbb.log_name('/a/intel-corrected.log.gz') == 'intel'
    assert gbb.log_name('fhw.log') == 'fhw'
    assert gbb.parse_pairs(['ic=--line-period 0.1'], '--convert') == {'ic': '--line-period 0.1'}
    with pytest.raises(ValueError, match='--convert ic: expected NAME=VALUE'):
        gbb.parse_pairs(['ic'], '--convert')


def test_buildings_with_a_peer_beside_them(tmp_path, capsys):
    log = tmp_path / 'room-corrected.log'
    log.write_text(corrected_room_log())
    out = tmp_path / 'out'
    args = [str(log), '--out', str(out), '--seeds', '0-1', '--gmapping', _peer(tmp_path), '--gmapping-seeds', '3']
    assert gbb.main(args) == 0
    printed = capsys.readouterr().out

    # The harness's log: one FLASER line per scan of the bag, the no-returns past any maxRange, the odometry of
    # the bag at the scan (the raw one: it turns 2 % too much, never the reference).
    lines = (out / 'gmapping' / 'room.log').read_text().splitlines()
    assert lines[0] == 'PARAM robot_frontlaser_offset 0.000000'
    flaser = [line.split() for line in lines[1:]]
    assert len(flaser) == 40 and all(f[0] == 'FLASER' and f[1] == '180' for f in flaser)
    assert flaser[0][2 + 90] == '10000' and flaser[1][2 + 90] != '10000'
    last = [float(v) for v in flaser[-1][2 + 180:2 + 183]]
    assert abs(math.atan2(math.sin(last[2]), math.cos(last[2])) - 2.0 * math.pi * 0.02) < 0.02

    # The peer ran once, with slam_gmapping's defaults, the scans' reach and its seed (3 + 1).
    args_text = (out / 'runs' / 'room' / 'gmapping' / 'seed3.args').read_text().split()
    assert args_text[0] == 'seed=4' and 'particles=30' in args_text and 'linearUpdate=1' in args_text
    assert any(a.startswith('maxRange=81.') for a in args_text)

    summary = json.loads((out / 'summary.json').read_text())['room']
    assert [r['seed'] for r in summary['ours']] == [0, 1] and [r['seed'] for r in summary['gmapping']] == [3]
    # The peer answered with the odometry: scored as the odometry is.
    assert summary['gmapping'][0]['ate'] == pytest.approx(summary['odometry_ate'], rel=1e-6)
    for r in summary['ours']:
        assert r['cpu'] > 0 and r['peak_mb'] > 0 and 0.0 <= r['coverage_95'] <= 1.0 and r['stated_sigma'] >= 0
    table = (out / 'table.md').read_text()
    assert table.strip() in printed
    row = [line for line in table.splitlines() if line.startswith('| room |')]
    assert len(row) == 1 and '40 (' in row[0] and ' of 2 |' in row[0]

    # A second call reuses the bag and the peer's run.
    record = out / 'runs' / 'room' / 'gmapping' / 'seed3.json'
    before = record.stat().st_mtime
    (out / 'runs' / 'room' / 'gmapping' / 'seed3.args').unlink()
    assert gbb.main(args[:4] + ['0', '--gmapping', args[6], '--gmapping-seeds', '3']) == 0
    assert record.stat().st_mtime == before
    assert not (out / 'runs' / 'room' / 'gmapping' / 'seed3.args').exists()
    assert 'reusing' in capsys.readouterr().err


def test_bad_arguments_are_one_line(tmp_path, capsys):
    log = tmp_path / 'room.log'
    log.write_text(corrected_room_log(8))
    assert gbb.main([str(log), '--out', str(tmp_path / 'o'), '--convert', 'other=--line-period 1']) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ['grid_buildings_benchmark: --convert other: no log of that name (room)']
    assert gbb.main([str(tmp_path / 'none.log'), '--out', str(tmp_path / 'o')]) == 1
    assert capsys.readouterr().err.strip().endswith('none.log: expected a file, got none')
    assert gbb.main([str(log), '--out', str(tmp_path / 'o'), '--gmapping', str(tmp_path)]) == 1
    assert 'expected a folder with build.sh' in capsys.readouterr().err
