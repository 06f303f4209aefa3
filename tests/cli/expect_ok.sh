#!/usr/bin/env bash
# expect_ok.sh REGEX CMD...: passes if CMD exits 0 and its combined output matches REGEX
# (ctest's PASS_REGULAR_EXPRESSION alone would ignore the exit status).
regex="$1"; shift
out=$("$@" 2>&1); rc=$?
echo "$out"
if [[ $rc -ne 0 ]]; then echo "expected exit status 0, got $rc"; exit 1; fi
if ! grep -Ezq "$regex" <<<"$out"; then echo "output does not match /$regex/"; exit 1; fi
exit 0
