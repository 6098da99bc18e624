#!/usr/bin/env bash
# Quick start, command 2: set up ./.venv if needed, then run the whole test suite.
source "$(dirname "$0")/venv.sh"
if [ $# -gt 0 ]; then
    exec python -m pytest "$@"
fi
# numba kernels do not check array bounds: a wrong index would be a crash, not an error.
# The kernel tests run once more with the checks compiled in (their own kernel cache).
# Each pass first compiles its kernels, mostly single-threaded Python, so the two run side
# by side, one per core; the bounds-check pass has fewer tests, so once it is done the
# same core runs the main pass's files listed in BESIDE, which the main pass leaves out.
BOUNDS_ENV=(NUMBA_BOUNDSCHECK=1 NUMBA_CACHE_DIR="$PWD/.venv/numba-boundscheck")
BOUNDS_TESTS=(tests/test_tracer.py tests/test_shading.py
    tests/test_reference.py tests/test_vm.py tests/test_primitives.py tests/test_limits.py
    tests/test_fuzz_systems.py tests/test_spheres.py tests/test_boxsplit.py
    tests/test_instance_table.py tests/test_packets.py tests/test_states.py tests/test_maps.py
    tests/test_cut.py tests/test_balls.py tests/test_union_order.py tests/test_operand_trees.py)
BESIDE=(tests/test_graftals.py tests/test_leaves.py tests/test_derivation.py)
# settle both kernel caches' stamps first (pcsg/trace/__init__.py), so that neither pass
# can drop kernels the other has just compiled
env "${BOUNDS_ENV[@]}" python -c "import pcsg.trace"
LOGS="$(mktemp -d)"
main=
other=
# Ctrl-C or SIGTERM ends every run and whatever its tests started: both cores' runs are
# process groups of their own (set -m), which the script waits for (so that it takes a
# signal at once, not when a pass ends) and ends whole; stdin is /dev/null for both, as
# for any command a script puts in the background
trap '[ -z "$main" ] || kill -- -"$main" 2>/dev/null || true
      [ -z "$other" ] || kill -- -"$other" 2>/dev/null || true
      rm -rf "$LOGS"' EXIT
trap 'echo "test.sh: interrupted, the test runs stopped" >&2; exit 130' INT
trap 'exit 143' TERM
# `logged NAME command...`: its output into $LOGS/NAME, its exit status into NAME_status
logged() {
    local name=$1
    shift
    "$@" > "$LOGS/$name" 2>&1 && echo 0 > "$LOGS/${name}_status" ||
        echo $? > "$LOGS/${name}_status"
}
set -m
(
    logged bounds env "${BOUNDS_ENV[@]}" python -m pytest -p no:cacheprovider "${BOUNDS_TESTS[@]}"
    logged beside python -m pytest -p no:cacheprovider "${BESIDE[@]}"
) < /dev/null &
other=$!
python -m pytest "${BESIDE[@]/#/--ignore=}" < /dev/null &
main=$!
set +m
# (venv.sh set -e: a failing pass must not end the script before the others' reports)
wait "$main" && main_status=0 || main_status=$?
main=
wait "$other" || true
other=
echo
echo "== the main pass's files run on the other core: ${BESIDE[*]#tests/} =="
cat "$LOGS/beside" 2>/dev/null || echo "(not run)"
echo
echo "== the kernel tests again, with array bounds checks (NUMBA_BOUNDSCHECK=1) =="
cat "$LOGS/bounds" 2>/dev/null || echo "(not run)"
for status in "$main_status" "$(cat "$LOGS/beside_status" 2>/dev/null || echo 1)" \
              "$(cat "$LOGS/bounds_status" 2>/dev/null || echo 1)"; do
    [ "$status" -eq 0 ] || exit "$status"
done
exit 0
