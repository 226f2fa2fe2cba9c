#!/usr/bin/env bash
# The whole suite, as `make test` runs it (after setup), in two lanes on the
# 2 cores:
#   * the node-graph tests (marker `graph`: real node processes over DDS,
#     paced by the simulated clock, which waits for the nodes it must not
#     outrun: hyper_nav_filter.clock_gate) on GRAPH_WORKERS pytest-xdist
#     workers (default 2; one test file per worker: --dist loadfile, so a file's
#     module-scoped graph is flown once), at normal priority. A
#     graph run is mostly waiting (discovery, pacing, drains: about 0.6 of a
#     core), so two at once nearly halve the lane (measured on a fresh clone:
#     one worker 996-1145 s, two 479 s; 9.0 CPU-min either way);
#   * beside them, the unit tests on two pytest-xdist workers at nice 19 (raised to
#     normal priority when the graph lane ends, so that other work cannot starve them): they
#     take the CPU the graphs leave idle (about 6 CPU-min).
# Each lane and each worker has its own ROS domain (a block of six derived
# from this shell's pid), so nothing crosses between lanes or with another
# suite running on the machine. Each lane ends with its slowest tests (wall)
# and its top CPU consumers (conftest.py: CPU does not depend on the load).
# Not --dist loadgroup: with pytest 9.2 and pytest-xdist 3.8 its xdist_group markers
# are silently ignored (xdist renames Node._nodeid, which pytest 9 no longer reads), and
# every graph file's module fixture was flown once on each worker that took one of its tests.
# Extra arguments go to both pytest runs (e.g. -k). Exit status: non-zero if either lane fails; the unit
# lane's output follows the graph lane's.
set -u
cd "$(dirname "$0")/.."
# shellcheck disable=SC1091
source tools/env.sh >/dev/null
base=$(( 10 + ($$ % 35) * 6 ))
unit_log="$(mktemp -d)/unit_tests.log"
ROS_DOMAIN_ID=$((base + 3)) HYPER_NAV_TEST_DOMAIN=$((base + 3)) nice -n 19 python -m pytest -c pytest.ini -n 2 --dist load -m "not graph" --cpu-top 25 --durations 15 "$@" \
    > "$unit_log" 2>&1 &
unit_pid=$!
trap 'kill -- -$unit_pid 2>/dev/null; kill $unit_pid 2>/dev/null' INT TERM
graph_workers=${GRAPH_WORKERS:-2}
graph_xdist=()
[ "$graph_workers" -gt 1 ] && graph_xdist=(-n "$graph_workers" --dist loadfile)
echo "[make test] node-graph tests on $graph_workers worker(s); unit tests beside them (nice 19, 2 workers; output below when done)"
ROS_DOMAIN_ID=$base HYPER_NAV_TEST_DOMAIN=$base python -m pytest -c pytest.ini -m graph "${graph_xdist[@]}" --cpu-top 25 --durations 15 "$@"
g=$?
# The graph lane is done, so the unit lane no longer has to yield to it: raised back to normal priority (root, or
# where RLIMIT_NICE allows it), else on a machine busy with other work it starves (at nice 19 beside two busy
# processes at nice 0 it got about 1 % of a core: 45 CPU-s in 40 min, fresh clone of e68fa9c).
raise_lane() { renice -n 0 -p "$1" >/dev/null 2>&1 || return 1; local c; for c in $(pgrep -P "$1"); do raise_lane "$c"; done; }
if kill -0 "$unit_pid" 2>/dev/null; then
    raise_lane "$unit_pid" && echo "[make test] graph lane done: unit lane raised to normal priority" \
        || echo "[make test] graph lane done: the unit lane's priority could not be raised (not permitted); it stays at nice 19"
fi
wait $unit_pid
u=$?
echo
echo "================================ unit tests ================================"
cat "$unit_log"
echo "[make test] node-graph tests: exit $g; unit tests: exit $u"
[ $g -eq 0 ] && [ $u -eq 0 ]
