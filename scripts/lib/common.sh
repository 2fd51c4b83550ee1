# Sourced by scripts/bootstrap, scripts/test and scripts/demo: paths and an environment in which
# Debian's ROS 1 works (see docs/development.md, "Platform notes").
RBPF_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
RBPF_WS="${RBPF_WS:-$RBPF_ROOT/build}"
# Debian's python3 carries the ROS modules; a pyenv or venv python3 first on PATH does not.
export PATH="/usr/bin:/bin:/usr/sbin:/sbin:$PATH"
export PYENV_VERSION=system
# Where the host name does not resolve, ROS nodes cannot reach each other by it.
if [ -z "${ROS_HOSTNAME:-}" ] && [ -z "${ROS_IP:-}" ] && ! getent hosts "$(hostname)" >/dev/null 2>&1; then
  export ROS_HOSTNAME=localhost
fi
export ROS_LOG_DIR="${ROS_LOG_DIR:-$RBPF_WS/log}"

# Configure flags of every workspace of this package (Debian's python3, tests on).
RBPF_CMAKE_COMMON=(-DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 -DCATKIN_ENABLE_TESTING=ON)

# Whether $1 is a catkin workspace (scripts/bootstrap's, scripts/test --sanitize's), made or being made.
rbpf_is_workspace() {
  [ -f "$1/.catkin_workspace" ] || [ -d "$1/src/rbpf_slam" ]
}

# Makes the catkin workspace $1 (a directory right under the repository root): $1/src/rbpf_slam mirrors the
# repository root with one link per top-level entry, the workspaces excepted. A single link to the root would
# put the workspace inside its own package, and every recursive search of the package (rosrun, roslaunch,
# catkin's package search) would loop through it or find the package again in another workspace.
rbpf_make_ws() {
  local ws="$1" pkg="$1/src/rbpf_slam" entry name
  [ ! -L "$pkg" ] || rm -f "$pkg"
  mkdir -p "$pkg"
  find "$pkg" -maxdepth 1 -type l ! -exec test -e {} \; -delete  # entries removed from the repo
  for entry in "$RBPF_ROOT"/*; do
    name=$(basename "$entry")
    if [ "$entry" -ef "$ws" ] || rbpf_is_workspace "$entry"; then
      [ ! -L "$pkg/$name" ] || rm -f "$pkg/$name"
    elif [ "$name" = package.xml ] || [ "$name" = nodelet_plugins.xml ]; then
      # hard links: these files are installed as they are found, and a relative symbolic link would not
      # resolve in the install space
      rm -f "$pkg/$name"
      ln "$entry" "$pkg/$name"
    else
      ln -sfn "../../../$name" "$pkg/$name"
    fi
  done
}

rbpf_source_ws() {
  # shellcheck disable=SC1091
  set +u
  source "$RBPF_WS/devel/setup.bash"
  set -u
}
