#!/usr/bin/env bash
# Install the Debian packages the tests need besides the Python venvs, when they are missing:
#
#   glslang-tools    glslangValidator: compiles docs/shaders/wrinkle_blend.glsl and .hlsl
#   spirv-cross      turns the HLSL's SPIR-V back into GLSL, so the HLSL runs too
#   libegl-mesa0     EGL with Mesa's surfaceless platform: OpenGL with no window or display
#   libgl1-mesa-dri  Mesa's drivers, llvmpipe (software) among them
#   libosmesa6       OSMesa, the other way to an off-screen OpenGL context
#   chromium         headless Chromium with software WebGL (SwiftShader): three.js renders an
#                    exported .glb in it (tests/blender/test_export_engines.py)
#
# and, with the machine's npm, the Khronos glTF validator into tests/tools/gltf_validator/
# and three.js's and Babylon.js's glTF loaders into tests/tools/engines/ (npm ci: the
# versions their package-lock.json files pin), which the glTF export's tests run.
#
# (tests/core/test_shaders.py and tests/blender/test_shaders_ict.py, through
# tests/core/glsl_runner.py.)  Idempotent: a package already installed is left alone, and
# apt-get update runs only when the install fails (an old package list).
#
# Exit status: 0 ready, 1 could not install (the tests that need them then skip, or fail
# with CI=true), 3 no apt here or no right to use it, outside CI (tools/test.sh: SKIP).
set -uo pipefail

PACKAGES=(glslang-tools spirv-cross libegl-mesa0 libgl1-mesa-dri libosmesa6 chromium)
log() { echo "[setup_system] $*"; }
in_ci() { [[ -n ${CI:-} && ${CI,,} != false && ${CI} != 0 ]]; }
cannot() {
    log "$*"
    in_ci && return 1
    return 3
}

missing=()
if command -v dpkg-query >/dev/null 2>&1; then
    for p in "${PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
    done
else
    cannot "no dpkg here (not Debian): install the equivalents of ${PACKAGES[*]} by hand"
    exit $?
fi
# The Node packages the glTF tests run on the exported .glb, each pinned by its folder's
# package-lock.json: the Khronos glTF validator (tests/blender/test_export_gltf.py) and the
# engines' loaders (tests/blender/test_export_engines.py).
npm_folder() {
    local dir=$1 marker=$2 what=$3
    [[ -d $dir/node_modules/$marker ]] && { log "$what installed already"; return 0; }
    command -v npm >/dev/null 2>&1 || { cannot "no npm here: the $what tests need Node.js and npm"; return $?; }
    log "installing the $what (npm ci in $dir)"
    (cd "$dir" && npm ci --no-audit --no-fund) || { log "npm ci failed in $dir"; return 1; }
}
validator() {
    npm_folder tests/tools/gltf_validator gltf-validator "glTF validator" || return $?
    npm_folder tests/tools/engines three "engines' glTF loaders (three.js, Babylon.js)"
}
cd "$(dirname "${BASH_SOURCE[0]}")/.." || exit 1

if ((${#missing[@]} == 0)); then
    log "installed already: ${PACKAGES[*]}"
    validator
    exit $?
fi

SUDO=()
if ((EUID != 0)); then
    if command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
        SUDO=(sudo -n)
    else
        cannot "missing ${missing[*]}, and installing needs root: apt-get install ${missing[*]}"
        exit $?
    fi
fi
command -v apt-get >/dev/null 2>&1 || { cannot "missing ${missing[*]}, and there is no apt-get"; exit $?; }

export DEBIAN_FRONTEND=noninteractive
install() { "${SUDO[@]}" apt-get install -y --no-install-recommends "${missing[@]}"; }
log "installing ${missing[*]}"
if ! install; then
    log "apt-get install failed; apt-get update, then once more"
    if ! { "${SUDO[@]}" apt-get update && install; }; then
        log "could not install ${missing[*]}"
        exit 1
    fi
fi
log "installed ${missing[*]}"
validator
