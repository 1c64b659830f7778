#!/usr/bin/env python3
"""Summarises `rayfold bench --align` reports (JSON) for docs/results.md:
per scene, the alignment speed-up of the stereo pair and of the 8-view path
(tile and single-ray kernels, unfolded and folded xy), the cost model's error
over every choice, and how `auto` fared against the best fixed choice.

usage: align_tables.py out/bench/*-align.json > align-summary.md
"""
import json
import os
import statistics
import sys


def main(paths):
    reports = [(os.path.basename(p).removesuffix("-align.json"), json.load(open(p))) for p in sorted(paths)]
    print("| scene | kernel | stereo none | stereo xy | path 8 none | path 8 xy | path 16 none |")
    print("|---|---|---|---|---|---|---|")
    for name, r in reports:
        for kernel in ("tile", "single"):
            cells = []
            for scenario, views, fold in [("stereo", 2, "none"), ("stereo", 2, "xy"), ("path", 8, "none"),
                                          ("path", 8, "xy"), ("path", 16, "none")]:
                row = [x for x in r["rows"] if x["scenario"] == scenario and x["views"] == views
                       and x["fold"] == fold and x["kernel"] == kernel]
                cells.append(f'{row[0]["speedup"]:.2f}x' if row else "-")
            print(f"| {name} | {kernel} | " + " | ".join(cells) + " |")
    print()
    print("Aligned against alone, render time per view (trace + readback), medians of interleaved frames; "
          "every aligned view equal to the view alone bit for bit: "
          + ("yes" if all(r["exact"] for _, r in reports) else "NO") + ".")
    print()
    print("| scene | choices | model error, median abs | within 20% | auto / best measured, per scenario | "
          "probe ms |")
    print("|---|---|---|---|---|---|")
    for name, r in reports:
        errors = []
        for x in r["rows"]:
            for way in ("alone", "aligned"):
                m = x[f"{way}_measured_ms_per_view"]
                if m > 0:
                    errors.append(abs(x[f"{way}_predicted_ms_per_view"] - m) / m)
        autos = r.get("auto", [])
        ratio = ", ".join(f'{a["scenario"]} {a["views"]}: {a["picked_ms_per_view"] / a["best_ms_per_view"]:.2f}x'
                          for a in autos)
        probe = statistics.median(a["probe_ms"] for a in autos) if autos else 0
        within = sum(e <= 0.2 for e in errors) / len(errors) if errors else 0
        print(f"| {name} | {len(errors)} | {100 * statistics.median(errors):.0f}% | {100 * within:.0f}% | "
              f"{ratio} | {probe:.0f} |")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
