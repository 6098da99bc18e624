#!/usr/bin/env bash
# Quick start, command 1: set up ./.venv if needed, check the sample grammars and render
# each to renders/NAME.png at 640x480 (the README gallery is made by this command).
source "$(dirname "$0")/venv.sh"
pcsg check grammars/*.pcsg
pcsg render grammars/*.pcsg -o renders/ "$@"
