#!/usr/bin/env bash
# Write requirements-py313.lock (the Python 3.13 lane: Blender 5.1 / 5.2 LTS) from
# requirements.lock: the same pins line for line, except the ones the Blender generation
# decides (numpy 2, bpy 5.2) and bpy 5.2's own dependency cattrs, and without the block between
# "# py311 only" and "# end py311 only" (torch for vtcore[learn]: no local build for 3.13, so pip
# would download multi-GB CUDA wheels; its tests skip in that lane). Run it after editing
# requirements.lock; tests/test_locks.py fails until the two agree.
set -euo pipefail
cd "$(dirname "$0")/.."
NUMPY=2.5.5 BPY=5.2.3 CATTRS=26.2.1
{
    echo "# Python 3.13 lane (Blender 5.1 / 5.2 LTS: numpy 2, bpy 5.2), installed into .venv313 by"
    echo "# scripts/setup.sh. Generated from requirements.lock by scripts/lock_py313.sh: edit that."
    sed -e "/^# py311 only/,/^# end py311 only/d" -e "s/^numpy==.*/numpy==$NUMPY/" -e "s/^bpy==.*/bpy==$BPY/" \
        -e "s/^\(cantools==.*\)/\1\ncattrs==$CATTRS/" requirements.lock
} > requirements-py313.lock.tmp
mv requirements-py313.lock.tmp requirements-py313.lock
