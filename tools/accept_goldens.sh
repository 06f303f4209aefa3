#!/usr/bin/env bash
# Accepts new golden images: copies every <build>/golden_out/<backend>/<name>.actual.png written by
# a failing (or golden-less) golden test over tests/golden/<backend>/<name>.png. Review the
# .actual.png and .diff.png files first.
#   tools/accept_goldens.sh [build-dir]     (default build/release)
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ "${1:-}" == "-h" || "${1:-}" == "--help" ]]; then sed -n '2,5p' "$0"; exit 0; fi
build="${1:-build/release}"
shopt -s nullglob
n=0
for f in "$build"/golden_out/*/*.actual.png; do
  backend=$(basename "$(dirname "$f")")
  name=$(basename "$f" .actual.png)
  mkdir -p "tests/golden/$backend"
  cp "$f" "tests/golden/$backend/$name.png"
  echo "accepted tests/golden/$backend/$name.png"
  n=$((n+1))
done
echo "$n golden image(s) accepted"
