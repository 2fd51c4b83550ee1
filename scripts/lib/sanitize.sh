# scripts/test --sanitize: the gtests (every catkin_add_gtest target of CMakeLists.txt; the rostest gtests need
# a ROS master and are left to scripts/test) built with AddressSanitizer and UndefinedBehaviorSanitizer in a
# workspace of their own, build_sanitize/ (RelWithDebInfo), and run one executable after another. A sanitizer
# report stops its executable and fails it. Ends with a line "N passed, N failed, N skipped" as scripts/test.
#   bash scripts/lib/sanitize.sh      (RBPF_JOBS: parallel compile jobs, default 2)
set -uo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
RBPF_WS="$RBPF_ROOT/build_sanitize"
export ROS_LOG_DIR="$RBPF_WS/log"
start=$(date +%s)

"$RBPF_ROOT/scripts/bootstrap" --packages-only || { echo "0 passed, 1 failed, 0 skipped"; exit 1; }
rbpf_make_ws "$RBPF_WS"

SANITIZE="-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined"
CMAKE_ARGS=(-DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS=$SANITIZE" "-DCMAKE_EXE_LINKER_FLAGS=$SANITIZE"
            "-DCMAKE_SHARED_LINKER_FLAGS=$SANITIZE" "${RBPF_CMAKE_COMMON[@]}")
mapfile -t GTESTS < <(grep -oE '^\s*catkin_add_gtest\(\s*[A-Za-z0-9_]+' "$RBPF_ROOT/CMakeLists.txt" | sed -E 's/.*\(\s*//')
RESULTS="$RBPF_WS/build/test_results"
LOGS="$RBPF_WS/sanitize_logs"
rm -rf "$RESULTS" "$LOGS"
mkdir -p "$RESULTS/rbpf_slam" "$LOGS"
extra_failed=0

echo "== sanitized build of ${GTESTS[*]} (RelWithDebInfo, $SANITIZE; logs: $LOGS)"
built=()
for t in "${GTESTS[@]}"; do
  if catkin_make -C "$RBPF_WS" "${CMAKE_ARGS[@]}" "$t" -j"${RBPF_JOBS:-2}" >"$LOGS/build-$t.log" 2>&1; then
    built+=("$t")
  else
    grep -E "error" "$LOGS/build-$t.log" | head -n 40
    echo "building $t FAILED (log: $LOGS/build-$t.log)"
    extra_failed=$((extra_failed + 1))
  fi
done
build_done=$(date +%s)
echo "sanitized build: $((build_done - start)) s"

# Leaks are reported (LeakSanitizer) and fail the executable, except those of the system's libraries
# listed in lsan.supp. halt_on_error: the first report ends the run (its stack is the finding).
export ASAN_OPTIONS="detect_leaks=1:detect_stack_use_after_return=1:check_initialization_order=1:strict_init_order=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export LSAN_OPTIONS="suppressions=$RBPF_ROOT/scripts/lib/lsan.supp:print_suppressions=0${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
rbpf_source_ws
echo "== sanitized gtests (ASAN_OPTIONS=$ASAN_OPTIONS UBSAN_OPTIONS=$UBSAN_OPTIONS)"
for t in "${built[@]}"; do
  xml="$RESULTS/rbpf_slam/gtest-$t.xml"
  log="$LOGS/$t.log"
  t0=$(date +%s)
  timeout "${RBPF_SANITIZE_TIMEOUT:-3600}" "$RBPF_WS/devel/lib/rbpf_slam/$t" --gtest_output="xml:$xml" >"$log" 2>&1
  rc=$?
  echo "$t: exit $rc, $(( $(date +%s) - t0 )) s (log: $log)"
  grep -E "^\[  FAILED  \]|^SUMMARY: |runtime error:|^==[0-9]+==ERROR: " "$log" | head -n 20
  if [ $rc -ne 0 ] && ! grep -q "<failure" "$xml" 2>/dev/null; then
    # Stopped by a sanitizer (its report is in the log), crashed or timed out: a failure of its own, named
    # after the report's first line.
    first=$(grep -m1 -E "^SUMMARY: |runtime error:|^==[0-9]+==ERROR: " "$log")
    [ $rc -ne 124 ] || first="timed out after ${RBPF_SANITIZE_TIMEOUT:-3600} s"
    PYTHONPATH="$RBPF_ROOT/src" python3 - "$RESULTS/rbpf_slam/sanitizer-$t.xml" "$t" "exit $rc: ${first:-see $log}" <<'EOF'
import sys
from xml.sax.saxutils import quoteattr
from rbpf_slam.atomic import write_text
path, name, message = sys.argv[1:4]
write_text(path, '<testsuite name=%s tests="1" failures="1"><testcase classname=%s name="sanitized_run">'
           '<failure message=%s/></testcase></testsuite>\n' % (quoteattr(name), quoteattr(name), quoteattr(message)))
EOF
  fi
done
echo "sanitized run: $(( $(date +%s) - build_done )) s; in all $(( $(date +%s) - start )) s"

echo "== results"
python3 "$RBPF_ROOT/scripts/lib/junit_summary.py" "$RESULTS" "$extra_failed"
