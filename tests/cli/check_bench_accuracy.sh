#!/usr/bin/env bash
# check_bench_accuracy.sh CLI SCENE OUTDIR BACKEND: a smoke run of `penumbra bench accuracy` (a
# benchmark: nothing here checks a time). --sweep quick at 32 x 18 on one backend; passes when the
# command succeeds, accuracy.csv has the documented header and at least one row of every setting
# of the quick sweep (scenes without mesh bakes: no bakeResolution), every row names the scene, the
# sdf_trace pass and the backend, accuracy.md exists, and either the plots were written (a Python
# with matplotlib was found) or the command said clearly that they were skipped. No temporary
# files may be left in OUTDIR.
cli="$1"; scene="$2"; out="$3"; backend="$4"
rm -rf "$out"
log=$("$cli" bench accuracy --scenes "$scene" --backend "$backend" --width 32 --height 18 --frames 1 --warmup 0 \
  --sweep quick --no-cache -o "$out" 2>&1); rc=$?
echo "$log"
[[ $rc -eq 0 ]] || { echo "exit status $rc"; exit 1; }
status=0
csv="$out/accuracy.csv"
[[ -f "$csv" ]] || { echo "missing $csv"; exit 1; }
header="scene,pass,backend,setting,value,gpu_ms_median,frame_ms_median,depth_rel_mean,depth_rel_p99,depth_rel_max,depth_rel_rmse,depth_psnr_db,depth_ssim,silhouette_mismatch,id_mismatch,normal_mean_deg,normal_p99_deg,normal_max_deg,gpu_ms_min,frame_ms_min,mean_steps,pixels_reference,pixels_test,pixels_both,frames,baseline,device"
first=$(head -n 1 "$csv")
[[ "$first" == "$header" ]] || { echo "header: '$first'"; echo "expected: '$header'"; status=1; }
for setting in quality maxSteps hitEpsilon overRelaxation fieldSafety refineSteps; do
  n=$(grep -c "^$scene,sdf_trace,$backend,$setting," "$csv")
  [[ $n -ge 1 ]] || { echo "no row for setting $setting"; status=1; }
done
rows=$(($(wc -l <"$csv") - 1))
good=$(grep -c "^$scene,sdf_trace,$backend," "$csv")
[[ $rows -ge 7 && $good -eq $rows ]] || { echo "$rows rows, $good name the scene, pass and backend"; status=1; }
[[ -f "$out/accuracy.md" ]] || { echo "missing $out/accuracy.md"; status=1; }
if grep -q "plots skipped" <<<"$log"; then
  grep -Eq "apt-get install python3-matplotlib|--no-plots" <<<"$log" || { echo "no install hint for the plots"; status=1; }
else
  for m in depth_rel_p99 silhouette_mismatch normal_mean_deg; do
    [[ -s "$out/sdf_trace_$m.png" ]] || { echo "missing $out/sdf_trace_$m.png"; status=1; }
  done
fi
ls -A "$out" | grep -q '^\.' && { echo "temporary files left in $out"; status=1; }
exit $status
