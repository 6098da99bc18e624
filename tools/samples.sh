#!/usr/bin/env bash
# Quick start, command 1: set up ./.venv if needed, check the sample grammars and render
# each to renders/NAME.png at 640x480 (the README gallery is made by this command).
source "$(dirname "$0")/venv.sh"
pcsg check grammars/*.pcsg
pcsg render grammars/*.pcsg -o renders/ "$@"
# the growing tree as an animation (renders/growing_tree_frames/growing_tree.png); a rerun
# reuses the frames it finds finished
pcsg animate grammars/growing_tree.pcsg --frames 24 --size 320x240 --shadow-samples 2 \
    --path "1.6,1.2,0.4 -14,9,1.4 -8,-15,1.4 4.5,-10.5,1.6" \
    --at-path "0,0,0.3 0,0,2.5 0.3,0,2.3" -o renders/growing_tree_frames -q
# the kernels the samples do not call, compiled now rather than at a user's first call of
# them (the README's terrain at cnt=10 took 23 s more the first time, the Python API's
# trace 12 s): the bounding walk split over threads, and the API's trace
warm="$(mktemp -d)"
trap 'rm -rf "$warm"' EXIT
pcsg render grammars/carpenter_terrain.pcsg --set cnt=10 --size 16x12 -q -o "$warm/t.png" >/dev/null
python -c "import pcsg; pcsg.load('grammars/sierpinski.pcsg').trace([[3, -4, 2]], [[-3, 4, -2]])"
