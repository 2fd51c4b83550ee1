"""Python tools of rbpf_slam: converters of logs and data sets to rosbags, evaluation helpers."""
# Let the generated message modules (rbpf_slam.msg, in a catkin devel or install space) be found when
# this source package comes first on PYTHONPATH, as it does when the tools run from a source tree.
from pkgutil import extend_path

__path__ = extend_path(__path__, __name__)
