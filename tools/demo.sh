#!/usr/bin/env bash
# THE demo command:   bash tools/demo.sh [args for sample_scenes/demo.py]
# Sets up .venv45 (bpy 4.5) and runs the demo script with it.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

if [[ ! -f sample_scenes/demo.py ]]; then
    echo "demo.sh: sample_scenes/demo.py does not exist yet; there is no demo to run." >&2
    exit 1
fi
bash tools/setup_env.sh 45
exec .venv45/bin/python sample_scenes/demo.py "$@"
