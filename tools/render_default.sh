#!/usr/bin/env bash
# Quick start 1: install dependencies, build Release, fetch the npm meshes, render the default scene
# (scenes/default.json) headless to out/default.png and print the per-pass GPU/CPU table. Extra
# arguments go to `penumbra render` (e.g. --backend gl, --frames 10, --stats out/stats.json).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh release
mkdir -p out
build/release/tools/penumbra/penumbra render scenes/default.json -o out/default.png "$@"
