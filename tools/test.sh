#!/usr/bin/env bash
# Quick start, command 2: set up ./.venv if needed, then run the whole test suite.
source "$(dirname "$0")/venv.sh"
if [ $# -gt 0 ]; then
    exec python -m pytest "$@"
fi
python -m pytest || exit $?
# numba kernels do not check array bounds: a wrong index would be a crash, not an error.
# The kernel tests run once more with the checks compiled in (their own kernel cache).
NUMBA_BOUNDSCHECK=1 NUMBA_CACHE_DIR="$PWD/.venv/numba-boundscheck" \
    python -m pytest -p no:cacheprovider tests/test_tracer.py tests/test_shading.py \
    tests/test_reference.py tests/test_vm.py tests/test_primitives.py tests/test_limits.py \
    tests/test_fuzz_systems.py tests/test_spheres.py tests/test_boxsplit.py \
    tests/test_instance_table.py tests/test_packets.py tests/test_states.py
