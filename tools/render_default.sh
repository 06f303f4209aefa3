#!/usr/bin/env bash
# Quick start 1: install dependencies, build Release, render the default job headless to
# out/default.png and print the per-pass GPU-time table. Extra arguments go to `penumbra demo`
# (e.g. --backend gl).
set -euo pipefail
cd "$(dirname "$0")/.."
tools/setup.sh release
mkdir -p out
build/release/tools/penumbra/penumbra demo -o out/default.png "$@"
