#!/usr/bin/env bash
# The whole suite, as `make test` runs it (after setup), in two lanes on the
# 2 cores:
#   * the node-graph tests (marker `graph`: real node processes over DDS,
#     paced in real time) one at a time, at normal priority;
#   * beside them, the unit tests on two pytest-xdist workers at nice 19: they
#     take only the CPU the graphs leave idle (a graph run uses about 0.6 of the
#     2 cores on average), so no graph's real-time pacing competes with them.
# Each lane has its own ROS domain (a block of four derived from this shell's
# pid: graph lane, unit lane, its two workers), so nothing crosses between
# lanes or with another suite running on the machine. Extra arguments go to
# both pytest runs (e.g. -k, --durations=20). Exit status: non-zero if either
# lane fails; the unit lane's output follows the graph lane's.
set -u
cd "$(dirname "$0")/.."
# shellcheck disable=SC1091
source tools/env.sh >/dev/null
base=$(( 10 + ($$ % 50) * 4 ))
unit_log="$(mktemp -d)/unit_tests.log"
ROS_DOMAIN_ID=$((base + 1)) nice -n 19 python -m pytest -c pytest.ini -n 2 --dist loadgroup -m "not graph" "$@" \
    > "$unit_log" 2>&1 &
unit_pid=$!
trap 'kill -- -$unit_pid 2>/dev/null; kill $unit_pid 2>/dev/null' INT TERM
echo "[make test] unit tests running beside the graph tests (nice 19, 2 workers; output below when done)"
ROS_DOMAIN_ID=$base python -m pytest -c pytest.ini -m graph "$@"
g=$?
wait $unit_pid
u=$?
echo
echo "================================ unit tests ================================"
cat "$unit_log"
echo "[make test] node-graph tests: exit $g; unit tests: exit $u"
[ $g -eq 0 ] && [ $u -eq 0 ]
