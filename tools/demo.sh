#!/usr/bin/env bash
# THE demo command:   bash tools/demo.sh [--quick] [args for sample_scenes/demo.py]
# Sets up .venv45 (bpy 4.5) and runs the demo script with it: the showcase (every method on
# the sample head: stills and a clip), one scene per method, the pattern close-ups and the
# contact sheet, with its progress (scene i/N, render j/M, ETA) and, at the end, the list of
# the files it wrote. --quick: the showcase's beats only, in under two minutes.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

if [[ ! -f sample_scenes/demo.py ]]; then
    echo "demo.sh: sample_scenes/demo.py does not exist yet; there is no demo to run." >&2
    exit 1
fi
bash tools/setup_env.sh 45
exec .venv45/bin/python sample_scenes/demo.py "$@"
