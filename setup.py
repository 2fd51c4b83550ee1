# Installs the Python package src/rbpf_slam (used by catkin_python_setup(); not meant to be run by hand).
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(packages=['rbpf_slam'], package_dir={'': 'src'}))
