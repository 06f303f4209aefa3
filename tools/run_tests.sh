#!/usr/bin/env bash
# Quick start 2: install dependencies, build Release, run the whole test suite with CTest.
# Extra arguments go to ctest (e.g. -R Conformance). Set PENUMBRA_BACKEND=vulkan|gl to limit GPU
# tests to one backend.
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh release
ctest --preset release -j "$(nproc 2>/dev/null || echo 2)" "$@"
