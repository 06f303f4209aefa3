#!/usr/bin/env bash
# check_sdf_sample.sh PENUMBRA PSDF POINTS GOOD BADLINE: `penumbra sdf sample PSDF --points POINTS`
# on a points file with '#' comments (whole-line and trailing), blank lines and one bad line must
# print one finite distance for each of the GOOD good lines, report the bad line by its number
# (POINTS:BADLINE:) and exit with status 1.
cli="$1"; psdf="$2"; points="$3"; good="$4"; badline="$5"
errfile=$(mktemp)
stdout=$("$cli" sdf sample "$psdf" --points "$points" 2>"$errfile"); rc=$?
stderr=$(cat "$errfile"); rm -f "$errfile"
echo "stdout:"; echo "$stdout"; echo "stderr:"; echo "$stderr"
status=0
if [[ $rc -ne 1 ]]; then echo "expected exit status 1, got $rc"; status=1; fi
lines=$(grep -cE '^-?[0-9]+(\.[0-9]+)?(e[-+][0-9]+)?$' <<<"$stdout")
if [[ "$lines" -ne "$good" ]]; then echo "expected $good distances on stdout, got $lines"; status=1; fi
if ! grep -q -- "$points:$badline: expected three finite numbers" <<<"$stderr"; then
  echo "the bad line $badline is not reported as $points:$badline"; status=1
fi
if grep -E -- "$points:[0-9]+:" <<<"$stderr" | grep -vq -- "$points:$badline:"; then
  echo "a good line was reported as bad"; status=1
fi
exit $status
