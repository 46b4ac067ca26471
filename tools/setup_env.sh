#!/usr/bin/env bash
# Create or update a virtual environment with Blender as a Python module (bpy).
#
#   bash tools/setup_env.sh 45   -> .venv45: Python 3.11 + requirements/bpy45.txt
#   bash tools/setup_env.sh 52   -> .venv52: Python 3.13 + requirements/bpy52.txt
#
# Idempotent: the venv is created only when it is missing or broken, and pip runs only
# when the requirements file (or the interpreter) changed since the last successful
# install. That is tracked by a hash stamp stored inside the venv.
#
# Exit status: 0 ready, 1 error, 3 skipped because the interpreter is not installed
# (allowed for 52 only; tools/test.sh then skips the bpy 5.2 pass).
set -euo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.."
ROOT=$PWD

case "${1:-}" in
    45) PYVER=3.11 ;;
    52) PYVER=3.13 ;;
    *)
        echo "usage: bash tools/setup_env.sh 45|52" >&2
        exit 1
        ;;
esac
TAG=$1
VENV="$ROOT/.venv$TAG"
REQ="$ROOT/requirements/bpy$TAG.txt"
STAMP="$VENV/.requirements.sha256"

log() { echo "[setup_env $TAG] $*"; }

# Find a Python X.Y interpreter: pyenv first, then pyenv's folder, then PATH.
find_python() {
    local prefix candidate
    if command -v pyenv >/dev/null 2>&1 && prefix=$(pyenv prefix "$PYVER" 2>/dev/null); then
        for candidate in "$prefix/bin/python$PYVER" "$prefix/bin/python3"; do
            [[ -x $candidate ]] && { echo "$candidate"; return 0; }
        done
    fi
    for candidate in "${PYENV_ROOT:-$HOME/.pyenv}"/versions/"$PYVER".*/bin/python3; do
        [[ -x $candidate ]] && { echo "$candidate"; return 0; }
    done
    if candidate=$(command -v "python$PYVER" 2>/dev/null); then
        echo "$candidate"
        return 0
    fi
    return 1
}

if ! PYTHON=$(find_python); then
    if [[ $TAG == 52 ]]; then
        log "Python $PYVER not found (pyenv or PATH): skipping the bpy 5.2 environment."
        exit 3
    fi
    log "ERROR: Python $PYVER not found (tried 'pyenv prefix $PYVER', ~/.pyenv/versions, PATH)." >&2
    exit 1
fi

# (Re)create the venv if it is missing, broken, or built on another Python version.
if ! "$VENV/bin/python" -c "import sys; assert sys.version.startswith('$PYVER.')" 2>/dev/null; then
    log "creating $VENV with $PYTHON"
    "$PYTHON" -m venv --clear "$VENV"
else
    log "venv $VENV exists ($("$VENV/bin/python" --version))"
fi

# The stamp covers the requirements file and the exact interpreter version.
WANT=$( { cat "$REQ"; "$VENV/bin/python" -VV; } | sha256sum | cut -d' ' -f1)
HAVE=$(cat "$STAMP" 2>/dev/null || true)
if [[ $WANT == "$HAVE" ]]; then
    log "requirements up to date ($(basename "$REQ"), stamp ${WANT:0:12})"
    exit 0
fi

log "installing $(basename "$REQ") into $VENV ..."
rm -f "$STAMP"
"$VENV/bin/python" -m pip install --no-input --disable-pip-version-check -r "$REQ"
echo "$WANT" >"$STAMP"
log "done: $(grep -cEv '^\s*(#|$)' "$REQ") pinned packages installed"
