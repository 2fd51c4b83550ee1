"""package.xml's dependencies are rosdep keys that resolve on Debian, and the manifest is complete.

ROS package keys are resolved with Debian's own rosdep database (python3-rosdep2's debian.yaml). The system
keys (rosdep's base.yaml and python.yaml, which need a download) are checked against test/rosdep/system.yaml,
which gives what rosdep resolves them to on Debian. Every resolved Debian package must be known to apt."""
import os
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET

import pytest
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DEBIAN_DB = '/usr/share/python3-rosdep2/debian.yaml'

# rosdep system keys used by package.xml -> the Debian package(s) rosdep installs for them (scripts/test gives
# the same list to catkin_lint as a rosdep source).
with open(os.path.join(ROOT, 'test', 'rosdep', 'system.yaml')) as _f:
    SYSTEM_KEYS = {k: v['debian'] for k, v in yaml.safe_load(_f).items()}


def manifest():
    return ET.parse(os.path.join(ROOT, 'package.xml')).getroot()


def dependencies(kinds=None):
    out = []
    for e in manifest():
        if e.tag.endswith('depend') and (kinds is None or e.tag in kinds):
            out.append((e.tag, e.text.strip()))
    return out


def apt_knows(package):
    if shutil.which('dpkg-query') and subprocess.run(['dpkg-query', '-W', package], stdout=subprocess.DEVNULL,
                                                      stderr=subprocess.DEVNULL).returncode == 0:
        return True
    if shutil.which('apt-cache') is None:
        return False
    out = subprocess.run(['apt-cache', 'show', '--no-all-versions', package], stdout=subprocess.PIPE,
                         stderr=subprocess.DEVNULL).stdout
    return bool(out.strip())


@pytest.fixture(scope='module')
def debian_db():
    if not os.path.exists(DEBIAN_DB):
        pytest.skip('no Debian rosdep database (%s; package python3-rosdep2, installed by scripts/bootstrap)'
                    % DEBIAN_DB)
    with open(DEBIAN_DB) as f:
        return yaml.safe_load(f)


def test_every_key_resolves_to_debian_packages_apt_knows(debian_db):
    problems = []
    for tag, key in dependencies():
        if key in debian_db:
            resolved = debian_db[key].get('debian') or []
            if isinstance(resolved, dict):  # per-release lists
                resolved = [p for v in resolved.values() for p in (v or [])]
        elif key in SYSTEM_KEYS:
            resolved = SYSTEM_KEYS[key]
        else:
            problems.append('%s %s: not a rosdep key Debian resolves' % (tag, key))
            continue
        if not resolved:
            problems.append('%s %s: resolves to nothing on Debian' % (tag, key))
        problems += ['%s %s: Debian package %s unknown to apt' % (tag, key, p) for p in resolved if not apt_knows(p)]
    assert not problems, '\n'.join(problems)


def test_the_system_key_list_holds_only_keys_in_use():
    used = {k for _, k in dependencies()}
    assert set(SYSTEM_KEYS) <= used, 'listed but not used: %s' % sorted(set(SYSTEM_KEYS) - used)


def test_ros_packages_found_by_cmake_are_declared():
    """Every catkin component of CMakeLists.txt is a build dependency of package.xml."""
    with open(os.path.join(ROOT, 'CMakeLists.txt')) as f:
        cmake = f.read()
    block = re.search(r'find_package\(catkin REQUIRED COMPONENTS(.*?)\)', cmake, re.S).group(1)
    components = set(block.split())
    declared = {k for tag, k in dependencies(('depend', 'build_depend'))}
    assert components and components <= declared, 'undeclared: %s' % sorted(components - declared)


def test_python_imports_of_the_tools_are_declared():
    """Third-party modules the installed Python tools import are run dependencies."""
    modules = {'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'tqdm': 'python3-tqdm',
               'matplotlib': 'python3-matplotlib', 'yaml': 'python3-yaml', 'rospkg': 'python3-rospkg',
               'rospy': 'rospy', 'rosbag': 'rosbag'}
    sources = [os.path.join(ROOT, 'src', 'rbpf_slam', f) for f in os.listdir(os.path.join(ROOT, 'src', 'rbpf_slam'))
               if f.endswith('.py')]
    text = ''
    for path in sources:
        with open(path) as f:
            text += f.read()
    run = {k for tag, k in dependencies(('depend', 'exec_depend'))}
    missing = sorted(key for mod, key in modules.items()
                     if re.search(r'^\s*(import|from)\s+%s\b' % mod, text, re.M) and key not in run)
    assert not missing, 'imported but not run dependencies: %s' % missing


def test_release_files_and_manifest_fields():
    for name in ('LICENSE', 'CHANGELOG.rst', 'README.md'):
        assert os.path.isfile(os.path.join(ROOT, name)), name
    root = manifest()
    assert root.find('license').text.strip() == 'BSD-3-Clause'
    with open(os.path.join(ROOT, 'LICENSE')) as f:
        assert 'BSD 3-Clause' in f.read()
    version = root.find('version').text.strip()
    with open(os.path.join(ROOT, 'CHANGELOG.rst')) as f:
        changelog = f.read()
    assert re.search(r'^%s \(\d{4}-\d{2}-\d{2}\)\n-+$' % re.escape(version), changelog, re.M), \
        'CHANGELOG.rst has no section for version %s in catkin format' % version
    maintainer = root.find('maintainer')
    assert maintainer is not None and re.match(r'[^@\s]+@[^@\s]+\.[a-z]+$', maintainer.get('email', ''))
