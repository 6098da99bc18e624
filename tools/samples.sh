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
