#!/usr/bin/env python3
"""Sweeps of the inverse rendering over solver settings and over what breaks it.

  tools/sweep.py pareto    [options]   accuracy against speed: lighting basis (SH orders,
                                       Haar map sizes and coefficient budgets), visibility
                                       resolution, number of basis BRDFs, transport route,
                                       outer iterations, number of materials
  tools/sweep.py stability [options]   accuracy where methods fail: photo count, noise, JPEG
                                       quality, white balance, over-exposure, geometry
                                       smoothing, materials, illumination, interreflection;
                                       Haar against SH

Every setting is one `pipeline run CONFIG --set ... --until evaluate` in one shared
workspace, so the stages a setting does not change come from the cache. The numbers
are read from the evaluate stage's metrics.json (docs/METRICS.md): relighting PSNR
of held-out views under held-out maps, environment-map error, albedo PSNR, and the
wall-clock seconds of each stage (from its status file, so a cached stage reports
the time it took when it ran).

Outputs in --out (docs/images by default), for sweep S:
  sweep_S.csv        one row per setting (appended as runs finish; a rerun skips rows
                     it already has unless --rerun)
  sweep_S.gp         gnuplot script drawing the chart (rerun by hand: gnuplot sweep_S.gp)
  sweep_S.png/.svg   the chart
  sweep_S.md         the Markdown table for docs/RESULTS.md
Python standard library and gnuplot only (Debian gnuplot-nox).
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# gnuplot reads the CSV by column number (1 family, 2 label, 3 x, 4 status, 5 relight_psnr_db, ...,
# 12 solve_s) and knows no quoting: labels hold no commas, and the overrides (which may) come last.
COLUMNS = ["family", "label", "x", "status", "relight_psnr_db", "rerender_psnr_db", "envmap_rel_error",
           "light_dir_error_deg", "albedo_psnr_db", "visibility_s", "inverse_s", "solve_s", "wall_s", "overrides"]


def pareto_settings():
    """(family, label, x, overrides); x is the family's own axis value (for the table only)."""
    s = []
    for order in (2, 4, 8):
        s.append(("SH", f"SH order {order}", order, ["inverse.lighting_basis=sh", f"inverse.sh_order={order}"]))
    # No 64x64 Haar maps: the lighting step solves a dense 4096-unknown system per photo, 64 times
    # the 32x32 cost (about 20 minutes per full-resolution step here), far beyond this sweep.
    for res, budgets in ((16, (64, 256)), (32, (64, 256, 1024))):
        for budget in budgets:
            s.append((f"Haar {res}x{res}", f"Haar {res}² {budget} coeff.", budget,
                      ["inverse.lighting_basis=haar", f"inverse.env_resolution={res}",
                       f"inverse.transport_max_coefficients={budget}"]))
    for vis in (16, 64):
        s.append(("Haar 32x32 visibility", f"Haar 32² visibility {vis}²", vis, [f"visibility.resolution={vis}"]))
    for lobes, basis in ((1, "[lambertian]"), (2, "[lambertian, phong:50]")):
        s.append(("Haar 32x32 basis BRDFs", f"Haar 32² {lobes} basis BRDF{'s' if lobes > 1 else ''}", lobes,
                  [f"inverse.basis={basis}"]))
    # The seed's transport route (product projection + blended wavelet rotation) against the exact
    # pixel route of the default, at the default 32² maps.
    s.append(("Haar 32x32 wavelet route", "Haar 32² wavelet route", 32, ["inverse.transport=wavelet"]))
    # The alternation's length: the sweep config's 4 iterations (2 coarse) against the stage defaults.
    for iters in (8, 12):
        s.append(("Haar 32x32 iterations", f"Haar 32² {iters} iterations", iters,
                  [f"inverse.max_iterations={iters}", "inverse.coarse_iterations=3"]))
    # Model size: fewer and more materials than the default 6.
    for m in (3, 10):
        s.append(("Haar 32x32 materials", f"Haar 32² {m} materials", m, [f"inverse.materials={m}"]))
    return s


# Stability factors: (factor, [(level label, overrides)], index of the baseline level). The baseline
# level of every factor is the config itself, so it is computed once.
def stability_factors():
    return [
        ("photos", [(str(n), [f"synthesize.num_photos={n}", f"synthesize.num_lightings={max(1, n // 2)}",
                              "ingest.min_photos=1"] if n != 12 else []) for n in (1, 3, 6, 12, 24)], 3),
        ("noise (read sigma)", [("0.002", []), ("0.02", ["synthesize.noise_read=0.02",
                                                         "synthesize.noise_shot=0.004"])], 0),
        ("JPEG quality", [("80-95", []), ("20", ["synthesize.jpeg_quality_min=20",
                                                 "synthesize.jpeg_quality_max=20"])], 0),
        ("white balance error (EV)", [("0.15", []), ("0.75", ["synthesize.white_balance_jitter_ev=0.75"])], 0),
        ("exposure key", [("0.18", []), ("0.6", ["synthesize.exposure_key=0.6"])], 0),
        ("geometry (vertices)", [("5000", []),
                                 ("1500", ["mesh.target_vertices=1500"]),
                                 ("400", ["mesh.target_vertices=400"])], 0),
        ("materials", [("matte (1)", ["synthesize.num_materials=1"]), ("glossy (4)", [])], 1),
        ("illumination", [("mixed", []), ("sunny skies", ["synthesize.sky_fraction=1"])], 0),
        ("interreflection", [("off", []), ("on", ["synthesize.interreflection=true"])], 0),
    ]


# The stability sweep's two methods: Haar wavelets on 16x16 maps (the best relighting of the pareto sweep
# at a tenth of the 32x32 solve time) and spherical harmonics up to order 4 (25 coefficients).
METHODS = [("Haar 16²", ["inverse.lighting_basis=haar", "inverse.env_resolution=16"]),
           ("SH order 4", ["inverse.lighting_basis=sh", "inverse.sh_order=4"])]


def stability_settings(factors):
    s = []
    for factor, levels, _ in factors:
        for i, (label, overrides) in enumerate(levels):
            for method, m_over in METHODS:
                s.append((f"{factor}|{method}", label, i, overrides + m_over))
    return s


def num(v):
    return "NaN" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.6g}"


def read_rows(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def write_rows_atomic(path, rows):
    tmp = path + ".tmp"
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in COLUMNS})
    os.replace(tmp, path)


def write_text_atomic(path, text):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        f.write(text)
    os.replace(tmp, path)


def fmt_duration(s):
    s = int(round(s))
    return f"{s // 60}m{s % 60:02d}s" if s >= 60 else f"{s}s"


def progress(done, total, started, label):
    elapsed = time.time() - started
    eta = elapsed / done * (total - done) if done else float("nan")
    width = 24
    bar = "#" * int(width * done / total) + "-" * (width - int(width * done / total))
    eta_text = fmt_duration(eta) if done else "?"
    sys.stderr.write(f"\r[{bar}] {done}/{total} elapsed {fmt_duration(elapsed)} ETA {eta_text}  {label[:50]:50s}")
    sys.stderr.flush()


def run_setting(args, overrides, log):
    cmd = [args.pipeline, "run", args.config, "--workspace", args.workspace, "--until", "evaluate"]
    for o in args.common_set + overrides:
        cmd += ["--set", o]
    log.write("$ " + " ".join(cmd) + "\n")
    log.flush()
    t0 = time.time()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    log.write(p.stdout)
    wall = time.time() - t0
    if p.returncode != 0:
        # "pipeline: stage 'sfm' failed: <reason>": keep the stage name (the reason is in the log).
        stage = next((line.split("'")[1] for line in p.stdout.splitlines()
                      if line.startswith("pipeline: stage '") and "' failed" in line), "")
        return {"status": f"failed in {stage}" if stage else f"failed (exit {p.returncode})", "wall_s": num(wall)}
    with open(os.path.join(args.workspace, "summary.json")) as f:
        summary = json.load(f)
    eval_dir = next(s["output_dir"] for s in summary["stages"] if s["name"] == "evaluate")
    with open(os.path.join(eval_dir, "metrics.json")) as f:
        m = json.load(f)
    sec = m.get("seconds", {})
    row = {"status": "ok", "wall_s": num(wall)}
    for k in ("relight_psnr_db", "rerender_psnr_db", "envmap_rel_error", "light_dir_error_deg", "albedo_psnr_db"):
        row[k] = num(m.get(k))
    row["visibility_s"] = num(sec.get("visibility"))
    row["inverse_s"] = num(sec.get("inverse"))
    # Solve time of the method: visibility (per-vertex transport input) + inverse.
    row["solve_s"] = num((sec.get("visibility") or 0) + (sec.get("inverse") or 0))
    return row


def fval(r, k):
    try:
        v = float(r.get(k, "NaN"))
    except ValueError:
        return float("nan")
    return v


def pareto_front(rows, min_gain_db=0.01):
    """Labels of the settings no faster setting matches within min_gain_db of relighting PSNR."""
    pts = sorted((fval(r, "solve_s"), -fval(r, "relight_psnr_db"), r["label"]) for r in rows
                 if r["status"] == "ok" and not math.isnan(fval(r, "relight_psnr_db")))
    front, best = [], -float("inf")
    for t, neg_psnr, label in pts:
        if -neg_psnr > best + min_gain_db:
            best = -neg_psnr
            front.append(label)
    return front


def draw(gp_path, out_dir):
    for term in ("png", "svg"):
        p = subprocess.run(["gnuplot", "-e", f"term='{term}'", os.path.basename(gp_path)], cwd=out_dir,
                           capture_output=True, text=True)
        if p.returncode != 0:
            sys.stderr.write(f"gnuplot failed on {gp_path} ({term}):\n{p.stderr}\n")


GP_TERMINALS = """if (!exists("term")) term = 'png'
if (term eq 'svg') set terminal svg size {w},{h} dynamic noenhanced font "sans,11"; else set terminal pngcairo size {w},{h} noenhanced font ",11"
set output '{name}.'.term
set datafile separator ","
"""


def pareto_outputs(args, rows, name):
    front = set(pareto_front(rows))
    # Front CSV for the step line.
    fpath = os.path.join(args.out, name + "_front.csv")
    front_rows = sorted(((fval(r, "solve_s"), fval(r, "relight_psnr_db")) for r in rows if r["label"] in front))
    # Extend the last step to the slowest setting, so a one-point front still shows as a line.
    slowest = max((fval(r, "solve_s") for r in rows if r["status"] == "ok"), default=float("nan"))
    if front_rows and slowest > front_rows[-1][0]:
        front_rows.append((slowest, front_rows[-1][1]))
    write_text_atomic(fpath, "solve_s,relight_psnr_db\n" + "".join(f"{t:.6g},{p:.6g}\n" for t, p in front_rows))
    families = []
    for r in rows:
        if r["family"] not in families:
            families.append(r["family"])
    plots = [f"'{name}_front.csv' skip 1 using 1:2 with steps lw 2 lc rgb '#999999' title 'Pareto front'"]
    env_plots = []
    for i, fam in enumerate(families):
        style = f"with points pt {5 + 2 * (i % 4)} ps 1.6 lc {i + 1}"
        plots.append(f"'{name}.csv' skip 1 using (strcol(1) eq '{fam}' && strcol(4) eq 'ok' ? column(12) : 1/0):5 "
                     f"{style} title '{fam}'")
        env_plots.append(f"'{name}.csv' skip 1 using (strcol(1) eq '{fam}' && strcol(4) eq 'ok' ? column(12) : 1/0):7 "
                         f"{style} notitle")
    # Left: relighting PSNR (the front); right: environment-map error of the same runs.
    gp = GP_TERMINALS.format(w=1200, h=520, name=name)
    gp += (f"set multiplot layout 1,2 title '{args.title}'\n"
           "set logscale x\nset grid\nset key below\n"
           "set xlabel 'visibility + inverse wall time [s] (2 shared cores)'\n"
           "set ylabel 'relighting HDR-PSNR [dB] (held-out views and maps)'\n"
           "plot " + ", \\\n     ".join(plots) + "\n"
           "set ylabel 'environment-map relative error (upper hemisphere)'\n"
           "plot " + ", \\\n     ".join(env_plots) + "\nunset multiplot\n")
    gp_path = os.path.join(args.out, name + ".gp")
    write_text_atomic(gp_path, gp)
    draw(gp_path, args.out)
    lines = ["| setting | relight PSNR [dB] | re-render PSNR [dB] | env-map rel. error | albedo PSNR [dB] "
             "| visibility [s] | inverse [s] | on the front |", "|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: fval(r, "solve_s")):
        if r["status"] != "ok":
            lines.append(f"| {r['label']} | {r['status']} | | | | | | |")
            continue
        lines.append(f"| {r['label']} | {fval(r, 'relight_psnr_db'):.2f} | {fval(r, 'rerender_psnr_db'):.2f} "
                     f"| {fval(r, 'envmap_rel_error'):.3f} | {fval(r, 'albedo_psnr_db'):.2f} "
                     f"| {fval(r, 'visibility_s'):.1f} | {fval(r, 'inverse_s'):.1f} "
                     f"| {'yes' if r['label'] in front else ''} |")
    write_text_atomic(os.path.join(args.out, name + ".md"), "\n".join(lines) + "\n")


def stability_outputs(args, rows, name, factors):
    n = len(factors)
    cols = 3
    nrows = (n + cols - 1) // cols
    gp = GP_TERMINALS.format(w=1200, h=330 * nrows, name=name)
    gp += f"set multiplot layout {nrows},{cols} title '{args.title}'\nset grid\nset key top right\n"
    gp += "set ylabel 'relight PSNR [dB]'\n"
    ok = [fval(r, "relight_psnr_db") for r in rows if r["status"] == "ok"]
    ok = [v for v in ok if not math.isnan(v)]
    if ok:
        gp += f"set yrange [{math.floor(min(ok)) - 1}:{math.ceil(max(ok)) + 1}]\n"
    for factor, levels, base in factors:
        tics = ", ".join(f"\"{label}\" {i}" for i, (label, _) in enumerate(levels))
        gp += f"set title '{factor}'\nset xrange [-0.5:{len(levels) - 0.5}]\nset xtics ({tics})\n"
        plots = []
        for j, (method, _) in enumerate(METHODS):
            fam = f"{factor}|{method}"
            plots.append(f"'{name}.csv' skip 1 using (strcol(1) eq '{fam}' && strcol(4) eq 'ok' ? $3 : 1/0):5 "
                         f"with linespoints pt {7 + 2 * j} ps 1.2 lw 2 lc {j + 1} title '{method}'")
        gp += "plot " + ", \\\n     ".join(plots) + "\n"
    gp += "unset multiplot\n"
    gp_path = os.path.join(args.out, name + ".gp")
    write_text_atomic(gp_path, gp)
    draw(gp_path, args.out)
    # Table: one line per factor and level, both methods; breakdown = first level that loses
    # more than --breakdown-db against the baseline level.
    by_key = {(r["family"], r["label"]): r for r in rows}
    lines = ["| factor | level | " + " | ".join(f"{m} relight PSNR [dB] | {m} env-map error" for m, _ in METHODS)
             + " |", "|---|---|" + "---|---|" * len(METHODS)]
    breakdown = []
    for factor, levels, base in factors:
        for i, (label, _) in enumerate(levels):
            cells = []
            for method, _ in METHODS:
                r = by_key.get((f"{factor}|{method}", label))
                if r is None or r["status"] != "ok":
                    cells += [r["status"] if r else "not run", ""]
                else:
                    cells += [f"{fval(r, 'relight_psnr_db'):.2f}", f"{fval(r, 'envmap_rel_error'):.3f}"]
            mark = " (baseline)" if i == base else ""
            lines.append(f"| {factor} | {label}{mark} | " + " | ".join(cells) + " |")
        for method, _ in METHODS:
            b = by_key.get((f"{factor}|{method}", levels[base][0]))
            if b is None or b["status"] != "ok":
                continue
            ref, ref_env = fval(b, "relight_psnr_db"), fval(b, "envmap_rel_error")
            broke, held = [], []
            for i, (label, _) in enumerate(levels):
                r = by_key.get((f"{factor}|{method}", label))
                if r is None or i == base:
                    continue
                if r["status"] != "ok":
                    broke.append(f"{label} (failed)")
                    continue
                v, env = fval(r, "relight_psnr_db"), fval(r, "envmap_rel_error")
                text = f"{label} ({v - ref:+.1f} dB, env-map error {ref_env:.2f} → {env:.2f})"
                (broke if not (v >= ref - args.breakdown_db) else held).append(text)
            line = f"- **{factor}**, {method}: "
            line += ("breaks down at " + ", ".join(broke)) if broke else "holds"
            if held:
                line += ("; holds at " if broke else ": ") + ", ".join(held)
            breakdown.append(line)
    text = "\n".join(lines) + "\n\nWhere each method breaks down (relighting PSNR more than " \
        f"{args.breakdown_db:g} dB below its baseline level):\n\n" + "\n".join(breakdown) + "\n"
    write_text_atomic(os.path.join(args.out, name + ".md"), text)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sweep", choices=["pareto", "stability"])
    ap.add_argument("--config", default=os.path.join(ROOT, "tools/sweep_bunny.yaml"),
                    help="pipeline config of the scene (default: tools/sweep_bunny.yaml)")
    ap.add_argument("--workspace", default="/tmp/relight_sweep", help="shared pipeline workspace")
    ap.add_argument("--pipeline", default=os.path.join(ROOT, "build/bin/pipeline"), help="pipeline executable")
    ap.add_argument("--out", default=os.path.join(ROOT, "docs/images"), help="folder of the CSV, charts and table")
    ap.add_argument("--name", default="", help="output name (default: sweep_<sweep>)")
    ap.add_argument("--set", dest="common_set", action="append", default=[],
                    help="extra STAGE.OPTION=VALUE for every run (repeatable)")
    ap.add_argument("--only", default="", help="run only settings whose label or family contains one of these comma-separated texts")
    ap.add_argument("--rerun", action="store_true", help="run settings the CSV already has again")
    ap.add_argument("--plot-only", action="store_true", help="only redraw charts and tables from the CSV")
    ap.add_argument("--breakdown-db", type=float, default=1.5,
                    help="stability: a level breaks a method when it loses more than this against the baseline")
    ap.add_argument("--title", default="", help="chart title")
    args = ap.parse_args()
    name = args.name or f"sweep_{args.sweep}"
    if not os.path.isfile(args.config):
        sys.exit(f"sweep: config '{args.config}' does not exist")
    if not args.plot_only and not os.access(args.pipeline, os.X_OK):
        sys.exit(f"sweep: pipeline executable '{args.pipeline}' not found; build it or pass --pipeline")
    os.makedirs(args.out, exist_ok=True)
    if not args.title:
        args.title = ("Accuracy against speed" if args.sweep == "pareto" else "Stability") + \
            f": {os.path.basename(args.config)}"
    factors = stability_factors()
    settings = pareto_settings() if args.sweep == "pareto" else stability_settings(factors)
    csv_path = os.path.join(args.out, name + ".csv")
    rows = read_rows(csv_path)
    if not args.plot_only:
        have = {(r["family"], r["label"]) for r in rows if r["status"] == "ok"}
        todo = [s for s in settings if (args.rerun or (s[0], s[1]) not in have)
                and (not args.only or any(o in s[0] or o in s[1] for o in args.only.split(",")))]
        os.makedirs(args.workspace, exist_ok=True)
        log_path = os.path.join(args.workspace, name + ".log")
        started = time.time()
        with open(log_path, "a") as log:
            for k, (family, label, x, overrides) in enumerate(todo):
                progress(k, len(todo), started, f"{family}: {label}")
                row = {"family": family, "label": label, "x": x, "overrides": " ".join(overrides)}  # last column
                row.update(run_setting(args, overrides, log))
                rows = [r for r in rows if (r["family"], r["label"]) != (family, label)] + [row]
                write_rows_atomic(csv_path, rows)
            progress(len(todo), max(1, len(todo)), started, "done")
        sys.stderr.write(f"\nlog: {log_path}\n")
    # CSV order: settings order, one family's rows together (gnuplot joins a family's points only when
    # no other family's row lies between them).
    order = {(s[0], s[1]): i for i, s in enumerate(settings)}
    x_of = {(s[0], s[1]): s[2] for s in settings}
    for r in rows:  # the level lists may have grown since a row was written
        r["x"] = x_of.get((r["family"], r["label"]), r["x"])
    families = list(dict.fromkeys(s[0] for s in settings))
    rows.sort(key=lambda r: (families.index(r["family"]) if r["family"] in families else 1 << 30,
                             order.get((r["family"], r["label"]), 1 << 30)))
    write_rows_atomic(csv_path, rows)
    if args.sweep == "pareto":
        pareto_outputs(args, rows, name)
    else:
        stability_outputs(args, rows, name, factors)
    print(f"wrote {csv_path} and {name}.{{gp,png,svg,md}} in {args.out}")


if __name__ == "__main__":
    main()
