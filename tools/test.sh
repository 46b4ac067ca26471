#!/usr/bin/env bash
# THE test command (CI runs it through .ci/run):   bash tools/test.sh [extra pytest args]
#
# Stages, in order; each prints a header and its duration, and a summary follows:
#   1. setup system        tools/setup_system.sh: the Debian packages of the shader tests
#                          (glslang, spirv-cross, Mesa's EGL/OSMesa); skipped where there
#                          is no apt outside CI; if it fails, those tests fail (CI) or skip
#   2. setup .venv45       tools/setup_env.sh 45 (bpy 4.5, Python 3.11); fatal if it fails
#   3. lint                ruff check (config: ruff.toml)
#   4. build               tools/build_extension.py: build + validate dist/*.zip
#   5. core without bpy    tests/core with `import bpy` blocked: core must not need Blender
#   6. pytest bpy 4.5      tests/ (core + blender)
#   7. setup .venv52       tools/setup_env.sh 52 (bpy 5.2, Python 3.13); skipped if no 3.13
#   8. pytest bpy 5.2      tests/ again
# A failing stage does not stop the later ones (except setup 4.5); the exit status is
# non-zero if any stage failed. For each pytest stage the summary also gives the counts
# (passed, failed, skipped ...) and every skip reason with its count, as tests/conftest.py
# records them in $WRINKLE_PYTEST_SUMMARY, so a PASS with skipped tests says why.
#
# Why pytest runs under a watchdog (see run_pytest): the bpy module can crash (SIGSEGV,
# SIGABRT) or hang while the interpreter exits, after every test has passed. Measured
# here: bpy 4.5.4 deadlocks forever at exit when a Python-function driver has run
# (also under pytest), and a plain script does when a non-persistent handler is left
# registered; bpy 5.2.3 exited cleanly in every case tried. tests/conftest.py therefore
# resets Blender to factory settings at the end of the session (which removes the
# cause), then writes pytest's own exit status to $WRINKLE_PYTEST_STATUS as its very last
# act. Here, if the process then dies by a signal, that recorded status is the verdict,
# and a line says so; if it is still alive WRINKLE_EXIT_GRACE seconds after writing the
# status, it is killed the same way. A run that never writes its status fails.
#
# Environment: WRINKLE_PYTEST_TIMEOUT (default 900 s per pytest run),
#              WRINKLE_EXIT_GRACE (default 60 s from status written to process gone).
set -uo pipefail

cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1
ROOT=$PWD
PYTEST_TIMEOUT=${WRINKLE_PYTEST_TIMEOUT:-900}
EXIT_GRACE=${WRINKLE_EXIT_GRACE:-60}
PYTEST_ARGS=("$@")

SUMMARY=()
FAILED=0
SKIPPED=200 # a stage function returns this when it had nothing to do
STAGE_DETAILS=() # lines a stage leaves for the summary, under its verdict (run_pytest's counts)

now_ms() { local t=${EPOCHREALTIME/[.,]/}; echo $((t / 1000)); }
seconds() { printf '%d.%ds' $(($1 / 1000)) $((($1 % 1000) / 100)); }

# run_stage NAME COMMAND...: header, run, duration, record PASS / SKIP / FAIL.
run_stage() {
    local name=$1 start rc elapsed verdict
    shift
    echo
    echo "======================================================================"
    echo "== $name"
    echo "======================================================================"
    start=$(now_ms)
    "$@"
    rc=$?
    elapsed=$(seconds $(($(now_ms) - start)))
    case $rc in
        0) verdict=PASS ;;
        "$SKIPPED") verdict=SKIP ;;
        *) verdict="FAIL (exit $rc)"; FAILED=1 ;;
    esac
    echo "== $name: $verdict in $elapsed"
    SUMMARY+=("$(printf '  %-16s %7s  %s' "$verdict" "$elapsed" "$name")")
    local line
    for line in "${STAGE_DETAILS[@]}"; do
        echo "== $name: $line"
        SUMMARY+=("$(printf '  %-16s %7s    %s' "" "" "$line")")
    done
    STAGE_DETAILS=()
    return $rc
}

lint() {
    local paths=() p
    for p in wrinkle_addon tests tools sample_scenes benchmarks; do
        [[ -e $p ]] && paths+=("$p")
    done
    .venv45/bin/ruff check "${paths[@]}"
}

# run_pytest PYTHON allow-no-tests|no -- PYTEST_ARGS...: pytest with the exit-crash and
# exit-hang handling described at the top of this file. Polls every 0.2 s (5 ticks/s).
PYTEST_PID=
run_pytest() {
    local python=$1 allow_no_tests=$2
    shift 3
    local status_file summary_file rc recorded ticks=0 ticks_after_status=0 killed="" line
    status_file=$(mktemp "${TMPDIR:-/tmp}/wrinkle-pytest-status.XXXXXX")
    summary_file=$(mktemp "${TMPDIR:-/tmp}/wrinkle-pytest-summary.XXXXXX")
    : >"$status_file" # empty until tests/conftest.py writes the status

    WRINKLE_PYTEST_STATUS=$status_file WRINKLE_PYTEST_SUMMARY=$summary_file \
        "$python" -m pytest "$@" </dev/null &
    PYTEST_PID=$!
    while kill -0 "$PYTEST_PID" 2>/dev/null; do
        if [[ -s $status_file ]]; then
            if ((ticks_after_status >= EXIT_GRACE * 5)); then
                killed="still running ${EXIT_GRACE}s after pytest finished (bpy exit hang)"
                kill -KILL "$PYTEST_PID" 2>/dev/null
            fi
            ticks_after_status=$((ticks_after_status + 1))
        elif ((ticks >= PYTEST_TIMEOUT * 5)); then
            killed="pytest took longer than ${PYTEST_TIMEOUT}s (WRINKLE_PYTEST_TIMEOUT)"
            kill -KILL "$PYTEST_PID" 2>/dev/null
        fi
        sleep 0.2
        ticks=$((ticks + 1))
    done
    wait "$PYTEST_PID"
    rc=$?
    PYTEST_PID=
    recorded=$(tr -d '[:space:]' <"$status_file")
    rm -f "$status_file"
    # Counts and grouped skip reasons, written by tests/conftest.py just before the status.
    while IFS= read -r line; do
        [[ -n $line ]] && STAGE_DETAILS+=("$line")
    done <"$summary_file"
    ((${#STAGE_DETAILS[@]})) || STAGE_DETAILS+=("no test counts recorded (pytest did not finish)")
    rm -f "$summary_file"

    [[ -n $killed ]] && echo "test.sh: killed the pytest process: $killed."
    if [[ -z $recorded ]]; then
        if ((rc > 128)); then
            echo "test.sh: pytest died by signal $(kill -l $((rc - 128)) 2>/dev/null || echo $((rc - 128))) before it finished; counting as failure."
        else
            echo "test.sh: pytest exited with $rc without recording its status (tests/conftest.py not loaded?); counting as failure."
        fi
        [[ $rc == 0 ]] && rc=1
    elif ((rc > 128)); then
        echo "test.sh: pytest finished with exit status $recorded; then the Python process died by" \
            "signal $(kill -l $((rc - 128)) 2>/dev/null || echo $((rc - 128))) during interpreter exit" \
            "(a known bpy shutdown problem, not a test result). Using pytest's recorded status $recorded."
        rc=$recorded
    elif [[ $rc != "$recorded" ]]; then
        echo "test.sh: note: process exit status $rc differs from pytest's recorded status $recorded; using $rc."
    fi
    if [[ $rc == 5 && $allow_no_tests == allow-no-tests ]]; then
        echo "test.sh: no tests collected here (pytest exit 5); allowed for this stage."
        rc=0
    fi
    return "$rc"
}

core_without_bpy() {
    # tests/core holds no core tests yet in an early tree: pytest's "no tests" is then fine.
    WRINKLE_NO_BPY=1 run_pytest .venv45/bin/python allow-no-tests -- tests/core "${PYTEST_ARGS[@]}"
}

setup_system() {
    bash tools/setup_system.sh </dev/null
    local rc=$?
    ((rc == 3)) && return "$SKIPPED" # no apt here (or no root), outside CI
    return "$rc"
}

setup52() {
    bash tools/setup_env.sh 52
    local rc=$?
    ((rc == 3)) && return "$SKIPPED" # setup_env.sh: no Python 3.13 here
    return "$rc"
}

# Sourced (`source tools/test.sh`), define the stages without running them, e.g. to try one:
#   source tools/test.sh; run_stage "pytest tools" run_pytest .venv45/bin/python no -- tests/tools
#   printf '%s\n' "${SUMMARY[@]}"
[[ ${BASH_SOURCE[0]} != "$0" ]] && return 0
trap '[[ -n $PYTEST_PID ]] && kill -KILL "$PYTEST_PID" 2>/dev/null; exit 130' INT TERM

echo "test.sh: repository $ROOT, CI=${CI:-}, $(nproc) cores"
run_stage "setup system packages" setup_system
run_stage "setup .venv45 (bpy 4.5)" bash tools/setup_env.sh 45 || {
    echo "test.sh: cannot continue without .venv45."
    exit 1
}
run_stage "lint (ruff)" lint
run_stage "build + validate extension" .venv45/bin/python tools/build_extension.py
run_stage "tests/core without bpy" core_without_bpy
run_stage "pytest on bpy 4.5" run_pytest .venv45/bin/python no -- tests --durations=5 "${PYTEST_ARGS[@]}"
if run_stage "setup .venv52 (bpy 5.2)" setup52; then
    run_stage "pytest on bpy 5.2" run_pytest .venv52/bin/python no -- tests --durations=5 "${PYTEST_ARGS[@]}"
elif [[ $? == "$SKIPPED" ]]; then
    SUMMARY+=("$(printf '  %-16s %7s  %s' SKIP - "pytest on bpy 5.2 (no Python 3.13)")")
fi

echo
echo "======================================================================"
echo "== summary"
printf '%s\n' "${SUMMARY[@]}"
if ((FAILED)); then
    echo "test.sh: FAILED"
    exit 1
fi
echo "test.sh: all stages passed"
