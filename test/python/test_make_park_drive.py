"""The park-drive scenario files are what scripts/make_park_drive makes (it is deterministic)."""
import os
import subprocess
import sys

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))


def test_committed_files_match_the_generator():
    result = subprocess.run([sys.executable, os.path.join(ROOT, 'scripts', 'make_park_drive'), '--check'],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, universal_newlines=True)
    assert result.returncode == 0, result.stderr
    assert 'park drive:' in result.stdout
