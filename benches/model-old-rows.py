#!/usr/bin/env python3
"""Rebuilds bench.json inputs for `cubetrace bench --model --model-from` from the rows of an
earlier model report (benches/results/lavapipe-model.json, the 2026-12-02 09:14-09:35 UTC
measurements at 160x120), whose original bench.json files were not kept.

Each row's measured ns per ray is written back as trace_ns.median = ns/ray x rays, with rays =
the scene's mirror pixels at 160x120 (from benches/results/lavapipe-bench.json, the same frame),
so `--model-from` reads exactly the measured ns per ray. One file per (subgroup, cube size).

These rows were looked at while the model was revised: a model scored on them is a TAINTED
check, not a validation (benches/model-measure.sh takes the new rows).

Usage: benches/model-old-rows.py OUT_DIR   (prints the files, comma-separated)
"""
import json
import os
import sys

root = os.path.dirname(os.path.abspath(__file__))
out = sys.argv[1]
os.makedirs(out, exist_ok=True)
model = json.load(open(os.path.join(root, "results/lavapipe-model.json")))
bench = json.load(open(os.path.join(root, "results/lavapipe-bench.json")))
rays = {r["scene"]: r["rays"] for r in bench["runs"] if r["width"] == 160}
label = {"fragment": "fragment-exact-mip"}
files = {}
for r in model["lavapipe"]["rows"]:
    key = (r["subgroup"], r["cube"])
    n = rays[r["scene"]]
    files.setdefault(key, []).append({
        "scene": r["scene"],
        "method": label.get(r["method"], r["method"]),
        "cube_size": r["cube"],
        "width": 160,
        "height": 120,
        "rays": n,
        "trace_ns": {"median": r["measured_ns_per_ray"] * n},
    })
paths = []
for (sg, cube), runs in sorted(files.items()):
    p = os.path.join(out, f"old-sg{sg}-cube{cube}.json")
    json.dump({"device": {"subgroup_size": sg}, "runs": runs}, open(p, "w"), indent=1)
    paths.append(p)
print(",".join(paths))
