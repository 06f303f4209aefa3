#!/usr/bin/env bash
# check_reference_cli.sh CLI SCENE OUTDIR: `penumbra reference` writes one PFM per requested AOV with
# the right header and size ("Pf"/"PF", 48 x 32, little-endian scale -1: a 14-byte header, then 4 bytes per float) and a JSON
# report with each image's standard error; the AO image has one.
cli="$1"; scene="$2"; out="$3"
rm -rf "$out"
"$cli" reference "$scene" -o "$out" --aov depth,normal,ids,ao,shadow --samples 16 --width 48 --height 32 -q || exit 1
status=0
check() {  # name magic channels
  local f="$out/$1.pfm"
  if [[ ! -f "$f" ]]; then echo "missing $f"; status=1; return; fi
  local header; header=$(head -c 14 "$f" | tr '\n' ' ')
  if [[ "$header" != "$2 48 32 -1.0 " ]]; then echo "$f: header '$header'"; status=1; fi
  local size; size=$(stat -c %s "$f")
  if [[ "$size" -ne $((14 + 48 * 32 * 4 * $3)) ]]; then echo "$f: $size bytes"; status=1; fi
}
check depth Pf 1; check normal PF 3; check ids Pf 1; check ao Pf 1; check shadow Pf 1
grep -q '"meanStdError"' "$out/reference.json" || { echo "no meanStdError in the report"; status=1; }
grep -Eq '"name": "ao"' "$out/reference.json" || { echo "no ao entry in the report"; status=1; }
ls -A "$out" | grep -q '^\.' && { echo "temporary files left in $out"; status=1; }
exit $status
