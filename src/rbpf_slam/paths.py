"""Where the tools find the package's own files and the data sets.

* :func:`package_file`: a file of the package (``config/...``): in the source tree beside this module when run
  from it, else where ROS finds the package (``share/rbpf_slam`` of an install space).
* :func:`data_dir`: a data set's folder: the one given, else ``$RBPF_SLAM_DATA/<name>``.
* :func:`program`: a compiled program of the package; :func:`script`: one of its Python entry points.
"""
import os

DATA_ENV = 'RBPF_SLAM_DATA'


def source_dir():
    """The source tree this module runs from (the folder holding package.xml, config/ and scripts/), else None
    (an installed module)."""
    here = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..'))
    if os.path.isfile(os.path.join(here, 'package.xml')) and os.path.isdir(os.path.join(here, 'config')):
        return here
    return None


def package_dir():
    """The package's folder (the one holding config/ and launch/)."""
    here = source_dir()
    if here:
        return here
    try:
        import rospkg
        return rospkg.RosPack().get_path('rbpf_slam')
    except Exception as e:  # rospkg missing, or the package not on ROS_PACKAGE_PATH
        raise RuntimeError('cannot find the package rbpf_slam (is a workspace\'s setup.bash sourced?): %s' % e)


def package_file(*parts):
    """A file of the package, e.g. package_file('config', 'grid_slam.yaml')."""
    return os.path.join(package_dir(), *parts)


def data_dir(given, name=''):
    """The folder of a data set: ``given`` if set, else $RBPF_SLAM_DATA/name; ValueError naming both if neither."""
    if given:
        return given
    root = os.environ.get(DATA_ENV, '')
    if not root:
        raise ValueError('no data: give --data DIR or set %s to the folder holding %s' %
                         (DATA_ENV, (name + '/') if name else 'the data sets'))
    return os.path.join(root, name) if name else root


def program(name):
    """A compiled program of the package (e.g. 'slam_bag'): in $RBPF_WS/devel/lib, a sourced workspace (devel or
    install, as rosrun finds it) or the source tree's build/devel; ValueError when none is built."""
    candidates = []
    if os.environ.get('RBPF_WS'):
        candidates.append(os.path.join(os.environ['RBPF_WS'], 'devel', 'lib'))
    candidates += [os.path.join(prefix, 'lib') for prefix in os.environ.get('CMAKE_PREFIX_PATH', '').split(':')
                   if prefix]
    candidates.append(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..', 'build', 'devel', 'lib'))
    for lib in candidates:
        path = os.path.join(lib, 'rbpf_slam', name)
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return path
    raise ValueError('%s: expected the built program (scripts/bootstrap builds it, or source a workspace), got none'
                     % name)


def script(name):
    """A Python entry point of the package (e.g. 'carmen_to_bag'), to run as ``[sys.executable, script(name)]``:
    the source tree's scripts/NAME when this module runs from one, else the installed one (lib/rbpf_slam, found as
    :func:`program` finds programs); ValueError when there is none."""
    here = source_dir()
    if here and os.path.isfile(os.path.join(here, 'scripts', name)):
        return os.path.join(here, 'scripts', name)
    return program(name)
