#!/usr/bin/env bash
# Quick start, command 1: set up ./.venv if needed, then check the sample grammars
# and print what they describe. (Rendering joins here when the tracer lands.)
source "$(dirname "$0")/venv.sh"
pcsg check grammars/*.pcsg
pcsg stats grammars/*.pcsg
