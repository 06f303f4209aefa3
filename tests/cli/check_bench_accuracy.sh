#!/usr/bin/env bash
# check_bench_accuracy.sh CLI SCENE OUTDIR BACKEND: a smoke run of `penumbra bench accuracy` (a
# benchmark: nothing here checks a time). --sweep quick at 32 x 18 (the effect rows too, their
# reference at --effect-error 0.2: 64 samples) on one backend; passes when the command succeeds,
# accuracy.csv has the documented header and at least one row of every setting of the quick sweep
# of each pass (sdf_trace; sdf_ao; sdf_shadow: the scene has shadowed lights, an "all" row and one
# per light; scenes without mesh bakes: no bakeResolution), every row names the scene, a pass and
# the backend, accuracy.md exists with the effect tables, and either the plots were written (a
# Python with matplotlib was found) or the command said clearly that they were skipped. No
# temporary files may be left in OUTDIR.
cli="$1"; scene="$2"; out="$3"; backend="$4"
rm -rf "$out"
log=$("$cli" bench accuracy --scenes "$scene" --backend "$backend" --width 32 --height 18 --frames 1 --warmup 0 \
  --effect-width 32 --effect-height 18 --effect-error 0.2 --sweep quick --no-cache -o "$out" 2>&1); rc=$?
echo "$log"
[[ $rc -eq 0 ]] || { echo "exit status $rc"; exit 1; }
status=0
csv="$out/accuracy.csv"
[[ -f "$csv" ]] || { echo "missing $csv"; exit 1; }
header="scene,pass,backend,setting,value,gpu_ms_median,frame_ms_median,depth_rel_mean,depth_rel_p99,depth_rel_max,depth_rel_rmse,depth_psnr_db,depth_ssim,silhouette_mismatch,id_mismatch,normal_mean_deg,normal_p99_deg,normal_max_deg,effect_mean,effect_p99,effect_max,effect_rmse,effect_psnr_db,effect_ssim,gpu_ms_min,frame_ms_min,mean_steps,pixels_reference,pixels_test,pixels_both,frames,baseline,device,light,ref_samples,ref_std_error_mean,ref_std_error_max"
first=$(head -n 1 "$csv")
[[ "$first" == "$header" ]] || { echo "header: '$first'"; echo "expected: '$header'"; status=1; }
for setting in quality maxSteps hitEpsilon overRelaxation fieldSafety refineSteps; do
  n=$(grep -c "^$scene,sdf_trace,$backend,$setting," "$csv")
  [[ $n -ge 1 ]] || { echo "no row for setting $setting"; status=1; }
done
for setting in quality resolutionScale maxSteps hard; do
  n=$(grep -c "^$scene,sdf_shadow,$backend,$setting,.*,all,[0-9]*,[^,]*,[^,]*$" "$csv")
  [[ $n -ge 1 ]] || { echo "no sdf_shadow 'all' row for setting $setting"; status=1; }
done
grep -q "^$scene,sdf_shadow,$backend,quality,medium,.*,0:[a-z]" "$csv" || { echo "no per-light sdf_shadow row"; status=1; }
for setting in quality five-tap multi-ray cones; do
  n=$(grep -c "^$scene,sdf_ao,$backend,$setting," "$csv")
  [[ $n -ge 1 ]] || { echo "no sdf_ao row for setting $setting"; status=1; }
done
rows=$(($(wc -l <"$csv") - 1))
good=$(grep -Ec "^$scene,sdf_(trace|shadow|ao),$backend," "$csv")
[[ $rows -ge 20 && $good -eq $rows ]] || { echo "$rows rows, $good name the scene, a pass and the backend"; status=1; }
grep -q "AO error per variant" "$out/accuracy.md" || { echo "accuracy.md: no AO table"; status=1; }
grep -q "Shadow error per light" "$out/accuracy.md" || { echo "accuracy.md: no shadow table"; status=1; }
[[ -f "$out/accuracy.md" ]] || { echo "missing $out/accuracy.md"; status=1; }
if grep -q "plots skipped" <<<"$log"; then
  grep -Eq "apt-get install python3-matplotlib|--no-plots" <<<"$log" || { echo "no install hint for the plots"; status=1; }
else
  for m in sdf_trace_depth_rel_p99 sdf_trace_silhouette_mismatch sdf_trace_normal_mean_deg sdf_shadow_effect_mean \
    sdf_ao_effect_p99; do
    [[ -s "$out/$m.png" ]] || { echo "missing $out/$m.png"; status=1; }
  done
fi
ls -A "$out" | grep -q '^\.' && { echo "temporary files left in $out"; status=1; }
exit $status
