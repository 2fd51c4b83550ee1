"""The released tree speaks of the package only: no paths of a build machine, no data defaults outside the
package, no words of how it was developed. Every text file under version control is read."""
import os
import re
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HERE = os.path.relpath(os.path.abspath(__file__), ROOT)

# Words of a development process, not of the package. Written split so that this file does not match itself.
WORDS = [
    r'\bissues? ?#?[0-9]+',
    r'\bsessions? ?[0-9]+',
    r'\bgo' r'als?\b',
    r'\bpin' r'ned\b',
    r'\bfire' r'wall\b',
    r'\bstu' r'dy\b',
    r'\bNOT ' r'MET\b',
    r'\btarg' r'ets?\s*(>=|\u2265|of\s+[0-9])',
    r'\bexample\.' r'org\b',
]
# Absolute paths of a machine, and the data directory beside the repository (tests and CI only read it).
PATHS = [
    r'(?<![\w.~$}])/(work|home|root|Users)/',
    r'\.\./sha' r'red\b',
]
PATHS_ALLOWED_UNDER = ('test/', '.ci/')


def tracked_files():
    try:
        out = subprocess.run(['git', 'ls-files', '-z'], cwd=ROOT, stdout=subprocess.PIPE,
                             stderr=subprocess.DEVNULL, check=True).stdout
        files = [f for f in out.decode('utf-8').split('\0') if f]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for d, dirs, names in os.walk(ROOT):
            dirs[:] = [x for x in dirs if not x.startswith('.') and x not in ('build', 'build_sanitize', '__pycache__')]
            files += [os.path.relpath(os.path.join(d, n), ROOT) for n in names]
    return sorted(f for f in files if os.path.isfile(os.path.join(ROOT, f)))


def text_of(rel):
    with open(os.path.join(ROOT, rel), 'rb') as f:
        data = f.read()
    if b'\0' in data:
        return None
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError:
        return None


def hits(patterns, allowed_under=()):
    found = []
    for rel in tracked_files():
        if rel == HERE or (allowed_under and rel.startswith(allowed_under)):
            continue
        text = text_of(rel)
        if text is None:
            continue
        for n, line in enumerate(text.splitlines(), 1):
            for p in patterns:
                if re.search(p, line, re.IGNORECASE):
                    found.append('%s:%d: %s' % (rel, n, line.strip()[:120]))
    return found


def test_the_tree_is_found():
    files = tracked_files()
    assert 'package.xml' in files and 'README.md' in files


def test_no_words_of_the_development_process():
    found = hits(WORDS)
    assert not found, 'words of the development process:\n' + '\n'.join(found)


def test_no_machine_paths_and_no_data_defaults_outside_the_package():
    found = hits(PATHS, PATHS_ALLOWED_UNDER)
    assert not found, 'absolute or workspace paths:\n' + '\n'.join(found)


@pytest.mark.parametrize('line,bad', [
    ('see iss' 'ue 12 for this', True), ('as in sess' 'ion 3', True), ('the go' 'al is met', True),
    ('pin' 'ned scenario', True), ('/wo' 'rk/main/config', True), ('../sha' 'red/data', True),
    ('go' 'al_tolerance: 0.3', False), ('path_follower target point', False), ('$HOME/maps', False),
    ('~/wo' 'rk/x', False), ('${prefix}/ho' 'me/x', False),
])
def test_the_patterns_catch_what_they_should(line, bad):
    assert any(re.search(p, line, re.IGNORECASE) for p in WORDS + PATHS) == bad
