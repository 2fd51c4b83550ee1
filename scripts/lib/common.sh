# Sourced by scripts/bootstrap, scripts/test and scripts/demo: paths and an environment in which
# Debian's ROS 1 works (see README "Platform notes").
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

rbpf_source_ws() {
  # shellcheck disable=SC1091
  set +u
  source "$RBPF_WS/devel/setup.bash"
  set -u
}
