#!/usr/bin/env bash
# in_fresh_dir.sh DIR CMD...: removes DIR (so that the command has to create it), then runs CMD.
dir="$1"; shift
rm -rf "$dir" || exit 1
exec "$@"
