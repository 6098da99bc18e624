#!/usr/bin/env bash
# Quick start, command 2: set up ./.venv if needed, then run the whole test suite.
source "$(dirname "$0")/venv.sh"
if [ $# -gt 0 ]; then
    exec python -m pytest "$@"
fi
# numba kernels do not check array bounds: a wrong index would be a crash, not an error.
# The kernel tests run once more with the checks compiled in (their own kernel cache).
# Both passes spend most of their time compiling kernels and in single-threaded Python,
# so they run side by side, one per core: 12.8 minutes one after the other on a fresh
# clone of this 2-core machine.
BOUNDS_ENV=(NUMBA_BOUNDSCHECK=1 NUMBA_CACHE_DIR="$PWD/.venv/numba-boundscheck")
# settle both kernel caches' stamps first (pcsg/trace/__init__.py), so that neither pass
# can drop kernels the other has just compiled
env "${BOUNDS_ENV[@]}" python -c "import pcsg.trace"
BOUNDS_LOG="$(mktemp)"
bounds=
# a script's `cmd &` ignores SIGINT: Ctrl-C would end the main pass and leave this one
# running on, so the script ends it itself
trap '[ -z "$bounds" ] || kill "$bounds" 2>/dev/null; rm -f "$BOUNDS_LOG"' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
env "${BOUNDS_ENV[@]}" \
    python -m pytest -p no:cacheprovider tests/test_tracer.py tests/test_shading.py \
    tests/test_reference.py tests/test_vm.py tests/test_primitives.py tests/test_limits.py \
    tests/test_fuzz_systems.py tests/test_spheres.py tests/test_boxsplit.py \
    tests/test_instance_table.py tests/test_packets.py tests/test_states.py tests/test_maps.py \
    tests/test_cut.py tests/test_balls.py tests/test_union_order.py tests/test_operand_trees.py \
    > "$BOUNDS_LOG" 2>&1 &
bounds=$!
# (venv.sh set -e: a failing pass must not end the script before the other's report)
python -m pytest && main_status=0 || main_status=$?
wait "$bounds" && bounds_status=0 || bounds_status=$?
bounds=
echo
echo "== the kernel tests again, with array bounds checks (NUMBA_BOUNDSCHECK=1) =="
cat "$BOUNDS_LOG"
[ "$main_status" -eq 0 ] || exit "$main_status"
exit "$bounds_status"
