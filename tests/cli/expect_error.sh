#!/usr/bin/env bash
# expect_error.sh REGEX CMD...: passes if CMD exits with status 1 or 2 (a clean error, not a
# crash or signal) and its combined output matches REGEX.
regex="$1"; shift
out=$("$@" 2>&1); rc=$?
echo "$out"
if [[ $rc -ne 1 && $rc -ne 2 ]]; then echo "expected exit status 1 or 2, got $rc"; exit 1; fi
if ! grep -Eq "$regex" <<<"$out"; then echo "output does not match /$regex/"; exit 1; fi
exit 0
