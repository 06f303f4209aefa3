#!/usr/bin/env python3
"""Plots of time against error from `penumbra bench accuracy`'s accuracy.csv (docs/ACCURACY.md).

    python3 tools/bench/plot_accuracy.py DIR/accuracy.csv -o DIR [--metrics a,b,...] [--dpi 72]

writes DIR/<pass>_<metric>.png for every pass in the CSV and every metric of that pass (sdf_trace: the
depth, silhouette, id and normal columns; sdf_shadow and sdf_ao: the effect_* columns, the shadow
pass's "all lights" rows only): one panel per scene (rows)
and backend (columns), x = the pass's median GPU ms, y = the metric, one colour per swept setting
(its value written next to the point, the medium preset as a star), and the Pareto front (no other
setting is both faster and more accurate) joined by a black step line and ringed. Needs matplotlib
(Debian: `sudo apt-get install python3-matplotlib`; it is installed for /usr/bin/python3).
"""

import argparse
import csv
import math
import os
import sys

# metric -> (axis label, higher is better)
METRICS = {
    "depth_rel_mean": ("depth: mean |relative error|", False),
    "depth_rel_p99": ("depth: p99 |relative error|", False),
    "depth_rel_max": ("depth: max |relative error|", False),
    "depth_rel_rmse": ("depth: RMSE of the relative error", False),
    "depth_psnr_db": ("depth: PSNR of the relative error (dB)", True),
    "depth_ssim": ("depth: SSIM (depth / max reference depth)", True),
    "silhouette_mismatch": ("silhouette mismatch (fraction of pixels hit in either)", False),
    "id_mismatch": ("entity id differs (fraction of pixels hit in both)", False),
    "normal_mean_deg": ("normal: mean angle error (degrees)", False),
    "normal_p99_deg": ("normal: p99 angle error (degrees)", False),
    "normal_max_deg": ("normal: max angle error (degrees)", False),
    # sdf_shadow (visibility of the shadowed lights, all together) and sdf_ao (AO), values in [0, 1]
    "effect_mean": ("mean |error|", False),
    "effect_p99": ("p99 |error|", False),
    "effect_max": ("max |error|", False),
    "effect_rmse": ("RMSE", False),
    "effect_psnr_db": ("PSNR (dB)", True),
    "effect_ssim": ("SSIM", True),
}
EFFECT_NAMES = {"sdf_shadow": "shadow visibility", "sdf_ao": "AO"}
SETTING_COLOURS = {
    "quality": "#000000",
    "maxSteps": "#1f77b4",
    "hitEpsilon": "#d62728",
    "overRelaxation": "#2ca02c",
    "fieldSafety": "#9467bd",
    "refineSteps": "#ff7f0e",
    "bakeResolution": "#8c564b",
    "resolutionScale": "#1f77b4",
    "hard": "#d62728",
    "five-tap": "#2ca02c",
    "multi-ray": "#9467bd",
    "cones": "#ff7f0e",
}


def metric_of_pass(pass_name, metric):
    """The effect passes have the effect_* columns, the trace the others."""
    return metric.startswith("effect_") == (pass_name != "sdf_trace")


def number(text):
    if text is None or text == "":
        return float("nan")
    try:
        return float(text)
    except ValueError:
        return float("nan")


def pareto(points, higher_is_better):
    """Indices of the points no other point dominates (time and error both no worse, one better)."""
    front = []
    for i, (t, e) in enumerate(points):
        if not (math.isfinite(t) and not math.isnan(e)):
            continue
        dominated = False
        for j, (tj, ej) in enumerate(points):
            if j == i or not (math.isfinite(tj) and not math.isnan(ej)):
                continue
            better_e = ej > e if higher_is_better else ej < e
            no_worse_e = ej >= e if higher_is_better else ej <= e
            if tj <= t and no_worse_e and (tj < t or better_e):
                dominated = True
                break
        if not dominated:
            front.append(i)
    return front


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("csv", help="accuracy.csv of penumbra bench accuracy")
    parser.add_argument("-o", "--output", required=True, help="folder for the PNG files")
    parser.add_argument("--metrics", default="", help="comma-separated metric columns (default: all but PSNR)")
    parser.add_argument("--dpi", type=int, default=72)
    args = parser.parse_args()

    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        sys.exit(
            "plot_accuracy.py: matplotlib is missing for %s; install it with "
            "`sudo apt-get install python3-matplotlib` (Debian; then run /usr/bin/python3)" % sys.executable
        )

    with open(args.csv, newline="") as f:
        # per-light shadow rows repeat their setting's time: the plots show the "all lights" rows
        rows = [r for r in csv.DictReader(f) if r.get("light", "") in ("", "all")]
    if not rows:
        sys.exit("plot_accuracy.py: %s has no rows" % args.csv)
    metrics = [m for m in args.metrics.split(",") if m] or [m for m in METRICS if "psnr" not in m]
    for m in metrics:
        if m not in rows[0]:
            sys.exit("plot_accuracy.py: %s has no column '%s'" % (args.csv, m))
    os.makedirs(args.output, exist_ok=True)

    def ordered(key, subset):
        seen = []
        for r in subset:
            if r[key] not in seen:
                seen.append(r[key])
        return seen

    written = []
    for pass_name in ordered("pass", rows):
        pass_rows = [r for r in rows if r["pass"] == pass_name]
        scenes = ordered("scene", pass_rows)
        backends = ordered("backend", pass_rows)
        for metric in metrics:
            if not metric_of_pass(pass_name, metric):
                continue
            label, higher = METRICS.get(metric, (metric, False))
            if pass_name in EFFECT_NAMES:
                label = "%s: %s" % (EFFECT_NAMES[pass_name], label)
            width = max(7.0, 4.4 * len(backends))
            height = 3.1 * len(scenes) + 0.7  # the title and the legend take 0.7 in at the top
            fig, axes = plt.subplots(len(scenes), len(backends), figsize=(width, height), squeeze=False)
            for si, scene in enumerate(scenes):
                for bi, backend in enumerate(backends):
                    ax = axes[si][bi]
                    group = [r for r in pass_rows if r["scene"] == scene and r["backend"] == backend]
                    pts = [(number(r["gpu_ms_median"]), number(r[metric])) for r in group]
                    ax.set_title("%s — %s" % (os.path.basename(scene), backend), fontsize=9)
                    ax.grid(True, which="both", alpha=0.25)
                    ax.tick_params(labelsize=7)
                    valid = [p for p in pts if math.isfinite(p[0]) and math.isfinite(p[1])]
                    if not valid:
                        ax.text(0.5, 0.5, "no data", ha="center", va="center", transform=ax.transAxes)
                        continue
                    for param in ordered("setting", group):
                        idx = [i for i, r in enumerate(group) if r["setting"] == param]
                        xs = [pts[i][0] for i in idx]
                        ys = [pts[i][1] for i in idx]
                        ax.scatter(xs, ys, s=16, color=SETTING_COLOURS.get(param, "#7f7f7f"), label=param, zorder=3)
                        for i in idx:
                            if math.isfinite(pts[i][0]) and math.isfinite(pts[i][1]):
                                ax.annotate(
                                    group[i]["value"], pts[i], fontsize=5.5, xytext=(2, 2),
                                    textcoords="offset points", color=SETTING_COLOURS.get(param, "#7f7f7f"),
                                )
                    base = [i for i, r in enumerate(group) if r.get("baseline") == "1"]
                    if base:
                        ax.scatter([pts[i][0] for i in base], [pts[i][1] for i in base], marker="*", s=70,
                                   facecolors="none", edgecolors="#444444", linewidths=0.8, zorder=4)
                    front = sorted(pareto(pts, higher), key=lambda i: pts[i][0])
                    if front:
                        fx = [pts[i][0] for i in front]
                        fy = [pts[i][1] for i in front]
                        ax.step(fx, fy, where="post", color="black", linewidth=0.9, zorder=2)
                        ax.scatter(fx, fy, s=60, facecolors="none", edgecolors="black", linewidths=0.9, zorder=5,
                                   label="Pareto front")
                    ys = [p[1] for p in valid]
                    positive = [y for y in ys if y > 0]
                    if positive and max(ys) > 0 and max(ys) / min(positive) > 20 and min(ys) >= 0:
                        if min(ys) > 0:
                            ax.set_yscale("log")
                        else:
                            ax.set_yscale("symlog", linthresh=min(positive))
                    xs = [p[0] for p in valid if p[0] > 0]
                    if xs and max(xs) / min(xs) > 10:
                        ax.set_xscale("log")
                    if si == len(scenes) - 1:
                        ax.set_xlabel("%s GPU ms (median)" % (pass_name + (" + effects_upsample" if pass_name in EFFECT_NAMES else "")), fontsize=8)
                    if bi == 0:
                        ax.set_ylabel(label, fontsize=7)
            handles, labels = [], []
            for row in axes:
                for ax in row:
                    for h, l in zip(*ax.get_legend_handles_labels()):
                        if l not in labels:
                            handles.append(h)
                            labels.append(l)
            top = 1.0 - 0.7 / height
            if handles:
                fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 1.0 - 0.25 / height),
                           ncol=min(len(labels), 8), fontsize=7, frameon=False)
            fig.suptitle("%s: time against %s (%s; star = medium preset)" % (pass_name, metric,
                         "higher is better" if higher else "lower is better"), fontsize=9, y=1.0 - 0.02 / height,
                         va="top")
            fig.tight_layout(rect=(0, 0, 1, top))
            path = os.path.join(args.output, "%s_%s.png" % (pass_name, metric))
            fig.savefig(path, dpi=args.dpi)
            plt.close(fig)
            written.append(path)
    print("plot_accuracy.py: wrote %d plot(s) to %s" % (len(written), args.output))


if __name__ == "__main__":
    main()
