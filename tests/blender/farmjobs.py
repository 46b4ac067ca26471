"""What the farm-job tests share: ``openjd-cli`` run on a job bundle."""

import os
import subprocess
import sys
from pathlib import Path

OPENJD = Path(sys.executable).parent / "openjd"  # pinned in requirements/, installed by tools/setup_env.sh


def openjd(*argv, env=None, log=None):
    """``openjd ARGV...`` (no PYTHONPATH unless ``env`` says otherwise); its output, also
    written to ``log``; a non-zero exit fails the test with the output's end."""
    assert OPENJD.is_file(), "openjd-cli is pinned in requirements/ and installed by tools/setup_env.sh"
    run = subprocess.run([str(OPENJD), *map(str, argv)], capture_output=True, text=True, timeout=600,
                         env=env or dict(os.environ, PYTHONPATH=""))
    if log is not None:
        log.write_text(run.stdout + run.stderr)
    assert run.returncode == 0, (run.stdout + run.stderr)[-4000:]
    return run.stdout + run.stderr
