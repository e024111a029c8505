#!/usr/bin/env bash
# Create or update the pinned virtual environments, one per Blender generation:
#   .venv     Python 3.11, numpy 1.26, bpy 4.5 LTS  (requirements.lock)        Blender 4.2 LTS .. 5.0
#   .venv313  Python 3.13, numpy 2,    bpy 5.2 LTS  (requirements-py313.lock)  Blender 5.1, 5.2 LTS
# Usage: scripts/setup.sh [py311] [py313]    (no argument: both)
# Idempotent: a second run only compares a checksum of each lock. Wheels come from
# pip's own cache (~/.cache/pip) after the first run; nothing is stored in the repo.
# PYTHON311 / PYTHON313 name the interpreters if they are not python3.11 / python3.13
# on PATH (PYTHON is still read for 3.11); pyenv installs are found on their own.
set -euo pipefail
cd "$(dirname "$0")/.."

lanes=("$@")
[ ${#lanes[@]} -gt 0 ] || lanes=(py311 py313)

# open3d links against libusb-1.0 (Debian package libusb-1.0-0).
if ! ldconfig -p 2>/dev/null | grep -q 'libusb-1.0.so.0'; then
    echo "setup: installing the Debian package libusb-1.0-0 (needed by open3d)" >&2
    SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libusb-1.0-0 >/dev/null
fi

# find_python X.Y [candidate]: print a command that runs CPython X.Y, or nothing.
find_python() {
    local want=$1 c prefix pv
    for c in ${2:-} "python$want"; do
        if "$c" -c "import sys; sys.exit(f'{sys.version_info[0]}.{sys.version_info[1]}' != '$want')" 2>/dev/null; then
            echo "$c"; return
        fi
    done
    # A pyenv shim answers "command not found" unless that version is selected: ask pyenv.
    if command -v pyenv >/dev/null 2>&1; then
        pv=$(pyenv versions --bare 2>/dev/null | grep -E "^${want//./\\.}\.[0-9]+$" | sort -V | tail -1 || true)
        if [ -n "$pv" ] && prefix=$(pyenv prefix "$pv" 2>/dev/null) && [ -x "$prefix/bin/python$want" ]; then
            echo "$prefix/bin/python$want"
        fi
    fi
}

# need_disk DIR MIB WHAT: refuse, before pip starts, to install into a disk that cannot hold
# it. pip fails late with "[Errno 28] No space left on device" and leaves a half-built venv;
# this says how much is needed, how much there is, and what usually takes the room.
need_disk() {
    local dir=$1 need=$2 what=$3 free
    free=$(df -Pm "$dir" 2>/dev/null | awk 'NR == 2 {print $4}')
    [ -n "$free" ] || return 0
    if [ "$free" -lt "$need" ]; then
        echo "setup: $what needs about $((need / 1024)).$(( (need % 1024) * 10 / 1024 )) GiB free" \
             "on the disk of $(cd "$dir" && pwd); only $free MiB are free. Free some room" \
             "(old clones' .venv / .venv313 folders take about 3.5 GiB each) and run it again." >&2
        exit 1
    fi
}

# lane VENV LOCK X.Y MIB [candidate]   (MIB: the venv's size once installed, plus a margin)
lane() {
    local venv=$1 lock=$2 want=$3 mib=$4 py stamp sum
    stamp=$venv/.$(basename "$lock").sha
    sum=$(sha256sum "$lock" pyproject.toml | sha256sum | cut -d' ' -f1)
    if [ -x "$venv/bin/python" ] && [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$sum" ]; then
        return
    fi
    # An existing venv is updated in place and needs less, but never more than a new one.
    need_disk . "$mib" "installing $lock into $venv"
    if [ ! -x "$venv/bin/python" ]; then
        py=$(find_python "$want" "${5:-}")
        if [ -z "$py" ]; then
            echo "setup: Python $want not found (needed for $venv, see $lock). Install it" \
                 "(Debian: apt-get install python$want python$want-venv; or pyenv install $want)," \
                 "or name it with PYTHON${want//./}=/path/to/python$want" >&2
            exit 1
        fi
        "$py" -m venv "$venv"
    fi
    echo "setup: installing $lock into $venv (first run takes a few minutes)" >&2
    "$venv/bin/python" -m pip install -q --upgrade "pip==26.3"
    "$venv/bin/python" -m pip install -q -r "$lock"
    "$venv/bin/python" -m pip install -q --no-deps --no-build-isolation -e .
    echo "$sum" > "$stamp"
}

for l in "${lanes[@]}"; do
    case $l in
        # Installed: .venv 3.6 GiB (torch 0.75 of it), .venv313 2.8 GiB (measured 2026-11-24).
        py311) lane .venv requirements.lock 3.11 4300 "${PYTHON311:-${PYTHON:-}}" ;;
        py313) lane .venv313 requirements-py313.lock 3.13 3400 "${PYTHON313:-}" ;;
        *) echo "setup: unknown lane '$l' (py311, py313)" >&2; exit 2 ;;
    esac
done
