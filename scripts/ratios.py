#!/usr/bin/env python3
"""Equal-time ratios from the compare runs: for every scene under docs/results,
the final relMSE and MAE of product relative to radiance and to pt (mean over runs
of each method's final row in curves.csv). Prints a markdown table; results.sh
appends it to docs/results.md. Numbers come only from the CSV files."""
import csv
import os
import sys

root = sys.argv[1] if len(sys.argv) > 1 else "docs/results"
scenes = ["cornell-box", "veach-mis", "veach-ajar", "staircase", "living-room"]


def finals(path):
    rows = list(csv.DictReader(open(path)))
    last = {}
    for r in rows:
        last[(r["method"], r["run"])] = r  # rows are in time order per run
    out = {}
    for (m, _), r in last.items():
        out.setdefault(m, []).append((float(r["relmse"]), float(r["mae"])))
    return {m: (sum(v[0] for v in vs) / len(vs), sum(v[1] for v in vs) / len(vs)) for m, vs in out.items()}


print("| scene | relMSE product/radiance | relMSE product/pt | MAE product/radiance | MAE product/pt |")
print("|---|---|---|---|---|")
for s in scenes:
    p = os.path.join(root, s, "curves.csv")
    if not os.path.exists(p):
        continue
    f = finals(p)
    if not all(m in f for m in ("pt", "radiance", "product")):
        continue
    pr, pm = f["product"]
    rr, rm = f["radiance"]
    tr, tm = f["pt"]
    print(f"| {s} | {pr / rr:.2f} | {pr / tr:.2f} | {pm / rm:.2f} | {pm / tm:.2f} |")
