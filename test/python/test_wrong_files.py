"""The tools' file arguments fed a wrong file (bytes that are no such file, under the name a user would give it):
each tool must end with a non-zero exit code and a message on stderr that names the file, never a traceback, and
leave no partial output behind (no bag, no hidden temporary). The converters' inputs are fed binary data in
test_converter_faults.py, slam_bag's in test_slam_bag_faults.py as well."""
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# (tool, arguments): {bad} is the wrong file (its name ends as the argument's files do), {out} a path for outputs.
CASES = [
    ('slam_bag', ['--bag', '{bad}.bag', '--out', '{out}']),
    ('slam_bag', ['--bag', '{bad}.bag', '--filter', 'grid', '--out', '{out}']),
    ('evaluate_bag_run', ['--bag', '{bad}.bag', '--run', '{run}']),
    ('trajectory_eval', ['--bag', '{bad}.bag']),
    ('calibrate_odometry', ['{bad}.bag', '-o', '{out}.yaml']),
    ('grid_benchmark', ['--bag', '{bad}.bag', '--seeds', '1']),
    ('grid_buildings_benchmark', ['{bad}-corrected.log.gz', '--seeds', '0', '--out', '{out}']),
    ('extract_trunks', ['{bad}.pcd', '--out', '{out}']),
    ('extract_trunks', ['{bad}.xyz', '--out', '{out}']),
    ('tree_view_benchmark', ['--cloud', '{bad}.pcd', '--stem', '0,0,0.2', '--out', '{out}']),
    ('plot_grid_run', ['{run}', '--reference', '{bad}.tum', '--out', '{out}.png']),
    ('plot_forest_run', ['{bad}.json', '--out', '{out}.png']),
    ('lifelong_benchmark', ['--worlds', '{bad}.yaml', '--seeds', '1', '--out', '{out}']),
]


def _wrong_file(path):
    # Bytes of every value: not text, not a bag, not a cloud, not an archive, not gzip.
    with open(path, 'wb') as f:
        f.write(bytes(range(256)) * 64)


def _run(tool, args, tmp_path):
    bad_stem = str(tmp_path / 'wrong')
    run_dir = tmp_path / 'run'
    run_dir.mkdir(exist_ok=True)
    for name in ('estimate.tum', 'odometry.tum'):
        (run_dir / name).write_text('1.0 0 0 0 0 0 0 1\n2.0 1 0 0 0 0 0 1\n')
    out = str(tmp_path / 'out' / 'result')
    os.makedirs(os.path.dirname(out), exist_ok=True)
    argv = []
    for a in args:
        if '{bad}' in a:
            path = a.replace('{bad}', bad_stem)
            _wrong_file(path)
            argv.append(path)
        else:
            argv.append(a.replace('{out}', out).replace('{run}', str(run_dir)))
    r = subprocess.run(['rosrun', 'rbpf_slam', tool] + argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                       universal_newlines=True, errors='replace', timeout=300)
    return r, [a for a in argv if a.startswith(bad_stem)][0]


@pytest.mark.parametrize('tool,args', CASES, ids=['%s-%s' % (c[0], os.path.splitext(
    [a for a in c[1] if '{bad}' in a][0])[1] or 'file') for c in CASES])
def test_a_wrong_file_is_named_without_a_traceback(tool, args, tmp_path):
    r, bad = _run(tool, args, tmp_path)
    assert r.returncode != 0, (tool, r.stdout[-2000:], r.stderr[-2000:])
    assert 'Traceback' not in r.stderr and 'Traceback' not in r.stdout, r.stderr[-3000:]
    assert os.path.basename(bad) in r.stderr, r.stderr[-2000:]
    partial = [os.path.join(d, f) for d, _, files in os.walk(str(tmp_path / 'out')) for f in files
               if f.startswith('.') or f.endswith(('.bag', '.bag.active', '.pcd', '.png'))]
    assert partial == [], partial
