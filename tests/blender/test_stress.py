"""The random-run harness (tools/stress.py) stays working: two short runs through the parent
are clean and reported as such, and a planted fault of each kind (an internal error of the
frame stage, a crash, a hang, a mesh that Disable Wrinkles does not restore) is caught in
its child process and makes the parent fail."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _stress(*args, timeout=600):
    run = subprocess.run([sys.executable, str(ROOT / "tools" / "stress.py"), *args], cwd=str(ROOT),
                         capture_output=True, text=True, timeout=timeout)
    return run.returncode, json.loads(run.stdout), run.stderr


def test_two_short_runs_are_clean():
    code, report, err = _stress("--runs", "2", "--actions", "4", "--seed", "7")
    assert code == 0, json.dumps(report, indent=1) + err
    assert report["runs"] == 2 and report["clean_runs"] == 2 and report["actions"] == 8
    for group in ("internal_errors", "crashes", "hangs", "restore_mismatches", "harness_errors"):
        assert report[group] == []


@pytest.mark.parametrize("fault, group", [("error", "internal_errors"), ("crash", "crashes"),
                                          ("hang", "hangs"), ("restore", "restore_mismatches")])
def test_a_planted_fault_is_reported_with_its_reproducer(fault, group):
    code, report, err = _stress("--runs", "1", "--first", "3", "--actions", "1", "--seed", "7",
                                "--inject", fault, "--timeout", "15" if fault == "hang" else "300")
    assert code == 1, err
    assert report["clean_runs"] == 0 and report[group], json.dumps(report, indent=1)
    found = report[group][0]
    assert (found["seed"], found["run"]) == (7, 3)
    assert "--replay 7 3" in found["replay"]
    if fault == "error":
        kinds = {p["kind"] for p in report[group]}
        assert kinds == {"internal_error"}, report[group]
        messages = " ".join(p["message"] for p in report[group])
        assert "planted by tools/stress.py" in messages and "Internal error" in messages
    elif fault == "crash":
        assert found["message"] == "killed by SIGABRT"
    elif fault == "restore":
        assert found["action"] == "final disable" and "positions differ" in found["message"]
