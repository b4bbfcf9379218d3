#!/usr/bin/env python3
"""Matchers side by side on one collection (issue 39): photo pairs compared, photos registered, camera
error against the truth and time, for each sfm.matcher on the same photos.

  python3 tools/matcher_compare.py --photos 160 --out /tmp/match160 \
      [--config configs/synthetic_tiny.yaml] [--matchers exhaustive retrieval] [--set sfm.retrieval_neighbors=20]

The chain runs to ingest once in OUT/photos (synthesize.num_photos = --photos, when the config
synthesizes); each matcher then runs the sfm stage in its own workspace OUT/<matcher> that starts from a
copy of it. Writes OUT/matchers.md (the table) and OUT/matchers.json. Timings are only comparable
between matchers run in the same session on an otherwise idle machine.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys


def stage_dir(ws, name):
    with open(os.path.join(ws, "summary.json")) as f:
        for s in json.load(f)["stages"]:
            if s["name"] == name:
                return s.get("output_dir", "")
    return ""


def run(cmd, log_path):
    print("matcher_compare:", " ".join(cmd), flush=True)
    with open(log_path, "w") as log:
        return subprocess.call(cmd, stdout=log, stderr=subprocess.STDOUT)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--config", default="configs/synthetic_tiny.yaml")
    p.add_argument("--photos", type=int, default=0, help="synthesize.num_photos (0: the config's)")
    p.add_argument("--matchers", nargs="+", default=["exhaustive", "retrieval"])
    p.add_argument("--set", action="append", default=[], help="extra STAGE.OPTION=VALUE for every run")
    p.add_argument("--out", required=True)
    p.add_argument("--build", default="build")
    args = p.parse_args()
    pipeline = os.path.join(args.build, "bin", "pipeline")
    os.makedirs(args.out, exist_ok=True)
    sets = []
    if args.photos > 0:
        sets += ["--set", f"synthesize.num_photos={args.photos}"]
    for s in args.set:
        sets += ["--set", s]

    base = os.path.join(args.out, "photos")
    if run([pipeline, "run", args.config, "--workspace", base, "--until", "ingest"] + sets,
           os.path.join(args.out, "photos.log")) != 0:
        sys.exit(f"matcher_compare: the run to ingest failed; see {args.out}/photos.log")
    ingest = stage_dir(base, "ingest")
    truth = os.path.join(ingest, "ground_truth")
    has_truth = os.path.exists(os.path.join(truth, "images.txt"))

    rows = []
    for matcher in args.matchers:
        ws = os.path.join(args.out, matcher)
        if not os.path.exists(ws):
            shutil.copytree(base, ws, symlinks=True)
        rc = run([pipeline, "run", args.config, "--workspace", ws, "--until", "sfm",
                  "--set", f"sfm.matcher={matcher}"] + sets, os.path.join(args.out, matcher + ".log"))
        row = {"matcher": matcher}
        sfm = stage_dir(ws, "sfm")
        summary_path = os.path.join(sfm, "sfm_summary.json")
        if rc != 0 or not os.path.exists(summary_path):
            row["error"] = f"sfm failed (exit {rc}); see {args.out}/{matcher}.log"
            rows.append(row)
            continue
        with open(summary_path) as f:
            s = json.load(f)
        with open(os.path.join(sfm, "status.json")) as f:
            status = json.load(f)
        steps = s.get("step_seconds", {})
        # Descriptor matching (its step includes retrieval's, which is also listed alone) and geometric
        # verification: what the choice of matcher changes.
        matching = sum(v for k, v in steps.items() if k.startswith(("match features", "verify")))
        row.update({
            "photos": s["num_photos"], "registered": s["num_registered"],
            "pairs_matched": s.get("num_pairs_matched"),
            "matching_seconds": round(matching, 1),
            "sfm_seconds": round(status.get("seconds", 0.0), 1),
            "peak_memory_mib": status.get("peak_memory_mib"),
        })
        if has_truth:
            cams = os.path.join(args.out, matcher + ".cameras.json")
            subprocess.call([os.path.join(args.build, "bin", "compare_cameras"), os.path.join(sfm, "sparse"), truth,
                             "--json", cams], stdout=subprocess.DEVNULL)
            if os.path.exists(cams):
                with open(cams) as f:
                    e = json.load(f)
                row["median_rotation_deg"] = round(e["median_rotation_deg"], 3)
                row["median_center_error_pct"] = round(100 * e["median_center_error_relative"], 3)
        rows.append(row)

    with open(os.path.join(args.out, "matchers.json"), "w") as f:
        json.dump(rows, f, indent=2)
    cols = ["matcher", "photos", "registered", "pairs_matched", "matching_seconds", "sfm_seconds",
            "peak_memory_mib", "median_rotation_deg", "median_center_error_pct", "error"]
    cols = [c for c in cols if any(c in r for r in rows)]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        lines.append("| " + " | ".join(str(r.get(c, "")) for c in cols) + " |")
    table = "\n".join(lines)
    with open(os.path.join(args.out, "matchers.md"), "w") as f:
        f.write(table + "\n")
    print(table)


if __name__ == "__main__":
    main()
