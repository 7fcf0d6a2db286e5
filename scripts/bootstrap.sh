#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
#
# Prepare everything `make demo` and `make test` need, and nothing more when it is already there:
#   1. the system libraries: Mesa EGL (the renderer's OpenGL 4.3 context) and the X/GL client
#      libraries the bpy module links against; installed with apt-get only when missing;
#   2. Python 3.11 (bpy 5.0.1 is built for 3.11 only) and the virtual environment .venv;
#   3. the pinned packages of requirements.txt, reinstalled only when that file changes
#      (a stamp file inside .venv remembers the last installed requirements).
#
# Environment: PYTHON=/path/to/python3.11 picks the interpreter; HYBRID_RT_SKIP_SYSTEM=1 skips
# step 1 (for machines managed otherwise).
set -euo pipefail

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$REPO_ROOT/.venv"
REQUIREMENTS="$REPO_ROOT/requirements.txt"
STAMP="$VENV/.requirements.sha256"
REQUIRED_PYTHON="3.11"

say() { printf 'bootstrap: %s\n' "$*" >&2; }
die() { printf 'bootstrap: error: %s\n' "$*" >&2; exit 1; }

# ---------------------------------------------------------------------------------------------
# apt-get, with sudo only when not root, and `apt-get update` only when an install needs it.
as_root() {
    if [ "$(id -u)" -eq 0 ]; then
        "$@"
    elif command -v sudo >/dev/null 2>&1; then
        sudo "$@"
    else
        die "need root (or sudo) to run: $*"
    fi
}

apt_install() {
    command -v apt-get >/dev/null 2>&1 ||
        die "missing system packages ($*) and no apt-get here: install them with your package manager"
    say "installing system packages: $*"
    export DEBIAN_FRONTEND=noninteractive
    if ! as_root apt-get install -y --no-install-recommends "$@" >/dev/null 2>&1; then
        say "package lists out of date or empty: running apt-get update"
        as_root apt-get update -qq >&2
        as_root apt-get install -y --no-install-recommends "$@" >&2
    fi
}

# ---------------------------------------------------------------------------------------------
# 1. System libraries. Each shared object is checked with ldconfig; the Mesa drivers (which are
#    loaded by EGL at run time and have no soname in the cache) are checked with dpkg.
#    soname -> Debian package
SYSTEM_LIBS=(
    "libEGL.so.1:libegl1"
    "libEGL_mesa.so.0:libegl-mesa0"
    "libgbm.so.1:libgbm1"
    "libGL.so.1:libgl1"
    "libX11.so.6:libx11-6"
    "libXrender.so.1:libxrender1"
    "libXfixes.so.3:libxfixes3"
    "libXi.so.6:libxi6"
    "libXext.so.6:libxext6"
    "libxkbcommon.so.0:libxkbcommon0"
    "libSM.so.6:libsm6"
    "libICE.so.6:libice6"
)
SYSTEM_DEBS=(libgl1-mesa-dri)

ensure_system_packages() {
    local missing=() entry soname pkg cache
    cache="$(ldconfig -p 2>/dev/null || /sbin/ldconfig -p 2>/dev/null || true)"
    for entry in "${SYSTEM_LIBS[@]}"; do
        soname="${entry%%:*}"
        pkg="${entry##*:}"
        grep -q "^[[:space:]]*${soname//./\\.} " <<<"$cache" || missing+=("$pkg")
    done
    if command -v dpkg >/dev/null 2>&1; then
        for pkg in "${SYSTEM_DEBS[@]}"; do
            dpkg -s "$pkg" 2>/dev/null | grep -q '^Status: install ok installed' || missing+=("$pkg")
        done
    fi
    if [ "${#missing[@]}" -gt 0 ]; then
        apt_install "${missing[@]}"
    fi
}

# ---------------------------------------------------------------------------------------------
# 2. Python 3.11 and the virtual environment.
python_version_of() { "$1" -c 'import sys; print("%d.%d" % sys.version_info[:2])' 2>/dev/null || true; }

find_python() {
    local candidate
    if [ -n "${PYTHON:-}" ]; then  # an explicit choice is checked, never second-guessed
        [ "$(python_version_of "$PYTHON")" = "$REQUIRED_PYTHON" ] && command -v "$PYTHON"
        return
    fi
    for candidate in python3.11 python3 /usr/bin/python3.11 /usr/local/bin/python3.11; do
        command -v "$candidate" >/dev/null 2>&1 || continue
        if [ "$(python_version_of "$candidate")" = "$REQUIRED_PYTHON" ]; then
            command -v "$candidate"
            return 0
        fi
    done
    return 1
}

ensure_python() {
    local python found=""
    if python="$(find_python)"; then
        echo "$python"
        return 0
    fi
    # Debian 12 and Ubuntu 22.04+ package Python 3.11; install it where that is possible.
    if [ -z "${PYTHON:-}" ] && command -v apt-get >/dev/null 2>&1; then
        say "no Python $REQUIRED_PYTHON found; trying apt-get"
        if apt_install python3.11 python3.11-venv && python="$(find_python)"; then
            echo "$python"
            return 0
        fi
    fi
    if [ -n "${PYTHON:-}" ]; then
        found="$(python_version_of "$PYTHON")"
        die "PYTHON=$PYTHON is ${found:+Python $found}${found:-not a runnable Python}; Python $REQUIRED_PYTHON is required (bpy 5.0.1)"
    fi
    for python in python3 python3.11; do
        command -v "$python" >/dev/null 2>&1 && found+=" $python=$(python_version_of "$python")"
    done
    die "Python $REQUIRED_PYTHON is required (bpy 5.0.1 supports only $REQUIRED_PYTHON); found:${found:- none}. \
Install python3.11 or set PYTHON=/path/to/python3.11"
}

ensure_venv() {
    local python="$1"
    if [ -x "$VENV/bin/python" ]; then
        if [ "$(python_version_of "$VENV/bin/python")" = "$REQUIRED_PYTHON" ]; then
            return 0
        fi
        say ".venv uses Python $(python_version_of "$VENV/bin/python"), not $REQUIRED_PYTHON: recreating it"
        rm -rf "$VENV"
    fi
    say "creating .venv with $python"
    if ! "$python" -m venv "$VENV" 2>/dev/null; then
        # Debian splits ensurepip into python3.X-venv.
        rm -rf "$VENV"
        apt_install "python${REQUIRED_PYTHON}-venv"
        "$python" -m venv "$VENV"
    fi
}

# ---------------------------------------------------------------------------------------------
# 3. Pinned packages, only when requirements.txt changed since the last successful install.
ensure_requirements() {
    local wanted
    wanted="$(sha256sum "$REQUIREMENTS" | cut -d' ' -f1)"
    if [ -f "$STAMP" ] && [ "$(cat "$STAMP")" = "$wanted" ]; then
        return 0
    fi
    say "installing pinned packages from requirements.txt (bpy is about 300 MB the first time)"
    "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check -r "$REQUIREMENTS"
    echo "$wanted" >"$STAMP"
}

main() {
    [ -f "$REQUIREMENTS" ] || die "no requirements.txt in $REPO_ROOT"
    if [ "${HYBRID_RT_SKIP_SYSTEM:-0}" != 1 ]; then
        ensure_system_packages
    fi
    local python
    python="$(ensure_python)"
    ensure_venv "$python"
    ensure_requirements
}

main "$@"
