#!/usr/bin/env python3
"""Cost curve: time and peak memory of every stage against the number of photos (issue 39).

Runs the pipeline on synthetic collections of each size (the config's generator settings with
synthesize.num_photos = N), one workspace per size, then reads each stage's status.json (seconds,
peak_memory_mib: the stage's process tree, COLMAP included) and writes

  OUT/cost_curve.csv   size, stage, status, seconds, peak_memory_mib
  OUT/cost_curve.txt   the table, a power-law fit per stage (seconds ~ a N^b over the sizes run) and
                       its projection to --project photos
  OUT/cost_curve.svg   seconds and peak memory per stage against photos, log-log (gnuplot)

  python3 tools/cost_curve.py --sizes 10 20 40 --out /tmp/cost [--config configs/synthetic_tiny.yaml]

A size already run is reused (the pipeline's cache); --until stops every run at a stage. The figures of
a run on a shared machine are noisy: compare sizes run in the same session.
"""
import argparse
import csv
import json
import math
import os
import shutil
import subprocess
import sys

STAGES = ["synthesize", "ingest", "sfm", "mvs", "mesh", "linearize", "visibility", "observe", "inverse",
          "relight", "evaluate", "report"]


def run_size(args, n):
    ws = os.path.join(args.out, f"n{n}")
    cmd = [os.path.join(args.build, "bin", "pipeline"), "run", args.config, "--workspace", ws,
           "--set", f"synthesize.num_photos={n}"]
    for s in args.set:
        cmd += ["--set", s]
    if args.until:
        cmd += ["--until", args.until]
    print("cost_curve:", " ".join(cmd), flush=True)
    with open(os.path.join(args.out, f"n{n}.log"), "w") as log:
        rc = subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT)
    rows = []
    summary_path = os.path.join(ws, "summary.json")
    if not os.path.exists(summary_path):
        sys.exit(f"cost_curve: the run of {n} photos wrote no {summary_path}; see {args.out}/n{n}.log")
    for stage in json.load(open(summary_path))["stages"]:
        status_path = os.path.join(stage["output_dir"], "status.json")
        if stage["status"] not in ("done", "cached") or not os.path.exists(status_path):
            rows.append((n, stage["name"], stage["status"], None, None))
            continue
        st = json.load(open(status_path))
        rows.append((n, stage["name"], stage["status"], st.get("seconds"), st.get("peak_memory_mib")))
    if rc != 0:
        print(f"cost_curve: the run of {n} photos stopped (exit {rc}); its finished stages are kept",
              file=sys.stderr)
    return rows


def power_fit(points):
    """Least-squares fit of log y = log a + b log x; None with fewer than two positive points."""
    pts = [(math.log(x), math.log(y)) for x, y in points if x > 0 and y and y > 0]
    if len(pts) < 2:
        return None
    mx = sum(p[0] for p in pts) / len(pts)
    my = sum(p[1] for p in pts) / len(pts)
    sxx = sum((p[0] - mx) ** 2 for p in pts)
    if sxx <= 0:
        return None
    b = sum((p[0] - mx) * (p[1] - my) for p in pts) / sxx
    return math.exp(my - b * mx), b


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", required=True, help="photo counts to run")
    ap.add_argument("--out", required=True, help="folder for the workspaces and the results")
    ap.add_argument("--config", default="configs/synthetic_tiny.yaml")
    ap.add_argument("--build", default="build")
    ap.add_argument("--set", action="append", default=[], help="extra STAGE.OPTION=VALUE for every run")
    ap.add_argument("--until", default="", help="stop every run after this stage")
    ap.add_argument("--project", type=int, default=1000, help="photo count to project the fit to")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)

    rows = []
    for n in sorted(set(args.sizes)):
        rows += run_size(args, n)
    with open(os.path.join(args.out, "cost_curve.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["photos", "stage", "status", "seconds", "peak_memory_mib"])
        w.writerows(rows)

    sizes = sorted(set(r[0] for r in rows))
    stages = [s for s in STAGES if any(r[1] == s for r in rows)]
    lines = []
    head = f"{'stage':<12}" + "".join(f"{f'{n} photos':>18}" for n in sizes)
    lines.append("seconds (peak MiB)")
    lines.append(head + f"{'fit: s ~ N^b':>14}{f'{args.project} photos':>16}")
    total_projection = 0.0
    for s in stages:
        cells, pts = [], []
        for n in sizes:
            r = next((r for r in rows if r[0] == n and r[1] == s), None)
            if r is None or r[3] is None:
                cells.append(f"{'-':>18}")
                continue
            cells.append(f"{f'{r[3]:.1f} ({r[4] or 0:.0f})':>18}")
            pts.append((n, r[3]))
        fit = power_fit(pts)
        if fit:
            a, b = fit
            proj = a * args.project ** b
            total_projection += proj
            tail = f"{b:>14.2f}{proj / 3600:>14.2f} h"
        else:
            tail = f"{'-':>14}{'-':>16}"
        lines.append(f"{s:<12}" + "".join(cells) + tail)
    totals = []
    for n in sizes:
        totals.append(sum(r[3] or 0 for r in rows if r[0] == n))
    lines.append(f"{'total':<12}" + "".join(f"{f'{t:.1f}':>18}" for t in totals) +
                 f"{'':>14}{total_projection / 3600:>14.2f} h")
    text = "\n".join(lines) + "\n"
    open(os.path.join(args.out, "cost_curve.txt"), "w").write(text)
    print(text, end="")

    if shutil.which("gnuplot") and len(sizes) >= 2:
        dat = os.path.join(args.out, "cost_curve.dat")
        with open(dat, "w") as f:
            for s in stages:
                f.write(f'"{s}"\n')
                for n in sizes:
                    r = next((r for r in rows if r[0] == n and r[1] == s and r[3] is not None), None)
                    if r:
                        f.write(f"{n} {max(r[3], 0.01)} {max(r[4] or 0, 0.1)}\n")
                f.write("\n\n")
        svg = os.path.join(args.out, "cost_curve.svg")
        script = f"""
set terminal svg size 1100,460 font "sans,11" background "white"
set output "{svg}"
set multiplot layout 1,2
set logscale xy
set xlabel "photos"
set key outside right
set grid
set title "time per stage [s]"
plot for [i=0:{len(stages) - 1}] "{dat}" index i using 1:2 with linespoints title columnheader(1)
set title "peak memory per stage [MiB]"
plot for [i=0:{len(stages) - 1}] "{dat}" index i using 1:3 with linespoints title columnheader(1)
unset multiplot
"""
        subprocess.run(["gnuplot"], input=script, text=True, check=False)
        print("cost_curve: wrote", svg)


if __name__ == "__main__":
    main()
