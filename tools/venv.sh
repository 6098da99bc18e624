# Sourced by the quick-start scripts: make ./.venv with pcsg, its test tools and the dask
# extra (so that the cluster tests run),
# reinstalling only when pyproject.toml changed. Needs only python3 (3.11+).
set -eu
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PY="${PYTHON:-python3}"
VENV="$ROOT/.venv"
if ! "$PY" -c 'import sys; sys.exit(sys.version_info < (3, 11))' 2>/dev/null; then
  echo "pcsg needs Python 3.11 or newer; '$PY' is $("$PY" --version 2>&1)" >&2
  exit 1
fi
STAMP="$VENV/.pcsg-installed"
WANT="$(cat "$ROOT/pyproject.toml" | "$PY" -c 'import hashlib,sys; print(hashlib.sha256(sys.stdin.buffer.read()).hexdigest())')"
if [ ! -x "$VENV/bin/python" ] || [ "$(cat "$STAMP" 2>/dev/null)" != "$WANT" ]; then
  echo "setting up $VENV (once) ..." >&2
  if ! "$PY" -m venv "$VENV"; then
    echo "'$PY -m venv' failed: on Debian and Ubuntu install python3-venv (apt-get install" \
         "python3-venv), or give another Python 3.11+ as PYTHON=..." >&2
    rm -rf "$VENV"
    exit 1
  fi
  "$VENV/bin/python" -m pip install --quiet --upgrade pip >&2
  "$VENV/bin/python" -m pip install --quiet -e "$ROOT[test,dask]" >&2
  echo "$WANT" > "$STAMP"
fi
# pcsg's modules as bytecode, as pip leaves an installed package: an editable install
# leaves that to the first import, which writes nothing where PYTHONDONTWRITEBYTECODE is
# set, and every start then compiled them again (0.05 s of a render's wall time)
"$VENV/bin/python" -m compileall -q "$ROOT/pcsg" >&2 ||
  echo "note: pcsg's modules could not all be compiled to bytecode; starts will be slower" >&2
export PATH="$VENV/bin:$PATH"
cd "$ROOT"
