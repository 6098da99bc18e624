#!/usr/bin/env bash
# The samples at 640x480 as one batch on a local Dask cluster of 1 and of 2 worker
# processes, alternately, twice (the machine may be shared: alternation spreads its
# load over both); then 2 workers with --tiles 4 (which splits the long terrain) and
# this process without Dask. Kernels are already compiled (a first small batch warms
# numba's cache); wall times include starting the cluster.
source "$(dirname "$0")/venv.sh"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
pcsg render grammars/*.pcsg --size 64x48 -o "$out/warm/" -q > /dev/null 2>&1
for run in "--workers 1" "--workers 2" "--workers 1" "--workers 2" "--workers 2 --tiles 4" ""; do
    start=$(date +%s.%N)
    line=$(pcsg render grammars/*.pcsg -o "$out/r/" --force $run 2>"$out/err" | tail -1)
    echo "${run:-no cluster}: $(echo "$(date +%s.%N) - $start" | bc) s wall; $line"
    grep "tasks per worker" "$out/err"
done
