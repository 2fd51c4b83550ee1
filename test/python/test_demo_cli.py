"""scripts/demo's options are checked before it bootstraps or runs anything."""
import os
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEMO = os.path.join(ROOT, 'scripts', 'demo')


def test_unknown_option_is_refused_before_any_work():
    r = subprocess.run([DEMO, '--no-such-option'], capture_output=True, text=True, timeout=30)
    assert r.returncode == 2
    assert 'unknown option --no-such-option' in r.stderr
    assert 'bootstrap' not in r.stdout  # nothing was built or installed


def test_help_names_the_modes():
    r = subprocess.run([DEMO, '--help'], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0
    for word in ('--headless', '--relay', '--seeds', 'report', 'forest_demo.launch'):
        assert word in r.stdout
