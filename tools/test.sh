#!/usr/bin/env bash
# Quick start, command 2: set up ./.venv if needed, then run the whole test suite.
source "$(dirname "$0")/venv.sh"
exec python -m pytest "$@"
