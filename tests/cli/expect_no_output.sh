#!/usr/bin/env bash
# expect_no_output.sh REGEX FORBIDDEN WORKDIR CMD...: WORKDIR is emptied (created if missing), then
# CMD runs; passes if CMD exits with status 1 or 2 (a clean error), its combined output matches
# REGEX and not FORBIDDEN (skipped when empty: e.g. a line printed only once the work has
# started), and WORKDIR is still empty afterwards: no output, no temporary file, no folder left
# behind by the failed command (every output path of CMD should lie inside WORKDIR, except the
# unwritable one the test is about).
regex="$1"; forbidden="$2"; workdir="$3"; shift 3
rm -rf "$workdir" && mkdir -p "$workdir" || exit 1
out=$("$@" 2>&1); rc=$?
echo "$out"
status=0
if [[ $rc -ne 1 && $rc -ne 2 ]]; then echo "expected exit status 1 or 2, got $rc"; status=1; fi
if ! grep -Eq "$regex" <<<"$out"; then echo "output does not match /$regex/"; status=1; fi
if [[ -n "$forbidden" ]] && grep -Eq "$forbidden" <<<"$out"; then
  echo "output matches /$forbidden/: the command started its work before failing"; status=1
fi
left=$(find "$workdir" -mindepth 1)
if [[ -n "$left" ]]; then echo "the failed command left files behind in $workdir:"; echo "$left"; status=1; fi
exit $status
