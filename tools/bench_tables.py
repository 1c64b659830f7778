#!/usr/bin/env python3
"""Combines `rayfold bench --json` reports into the Markdown tables of
docs/results.md: Table 1 (render time T, memory M) and Table 2 (pre-build,
update), one row per scene, one column group per method, ratios to the
culled unfolded baseline. Standard library only.

usage: tools/bench_tables.py out/bench/<scene>.json... > tables.md
       tools/bench_tables.py --peers out/bench/<scene>-peers.json... > peers.md
"""
import json
import os
import sys

METHODS = ["none (no culling)", "none", "y", "x", "xy"]


def load(paths):
    reports = []
    for p in paths:
        with open(p) as f:
            r = json.load(f)
        r["name"] = os.path.splitext(os.path.basename(p))[0]
        r["by_method"] = {m["method"]: m for m in r["methods"]}
        reports.append(r)
    return reports


def table1(reports):
    out = ["| scene | triangles | instances | " + " | ".join(f"T {m}" for m in METHODS) +
           " | M none MB | M xy / none | exact |",
           "|---|---|---|" + "---|" * len(METHODS) + "---|---|---|"]
    for r in reports:
        base = r["by_method"]["none"]
        cells = []
        for m in METHODS:
            t = r["by_method"][m]["render_ms"]
            cells.append(f"{t:.0f} ms ({base['render_ms'] / t:.2f}x)")
        mxy = r["by_method"]["xy"]["memory_bytes"] / base["memory_bytes"]
        out.append(f"| {r['name']} | {r['triangles']:,} | {r['instances']:,} | " + " | ".join(cells) +
                   f" | {base['memory_bytes'] / 2**20:.2f} | {mxy:.4f} | {'yes' if r['exact'] else 'NO'} |")
    return "\n".join(out)


def table2(reports):
    out = ["| scene | pre-build ms | " + " | ".join(f"update {m}" for m in METHODS) + " |",
           "|---|---|" + "---|" * len(METHODS)]
    for r in reports:
        base = r["by_method"]["none"]["update_ms"]
        cells = [f"{r['by_method'][m]['update_ms']:.2f} ms ({r['by_method'][m]['update_ms'] / base:.2f}x)"
                 for m in METHODS]
        out.append(f"| {r['name']} | {r['prebuild_ms']:.0f} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def peers_tables(paths):
    """The gap to Embree per scene, then every variant of every scene."""
    reports = []
    for p in paths:
        with open(p) as f:
            r = json.load(f)
        r["name"] = os.path.basename(p).replace("-peers.json", "")
        reports.append(r)
    r0 = reports[0]
    print(f"{r0['width']}x{r0['height']}, {r0['views']} views per scene, median of {r0['frames']} frames, "
          f"{r0['threads']} threads; rayfold device: {r0['device']}.\n")
    print("The gap: pixels answered per second (millions), and the share of pixels whose triangle differs from "
          "the double-precision reference\n")
    print("| scene | rayfold OpenCL exact, none | rayfold OpenCL exact, xy | rayfold CPU reference, xy | "
          "Embree rtcIntersect1 | Embree rtcIntersect16 | xy / Embree16 |")
    print("|---|---|---|---|---|---|---|")
    for r in reports:
        rows = {(x["variant"], x["fold"]): x for x in r["rows"]}

        def cell(key):
            x = rows.get(key)
            return f"{x['mpixels_per_s']:.1f} ({100 * x['disagreeing_share']:.3f}%)" if x else "-"

        e16 = rows.get(("Embree rtcIntersect16", "-"))
        xy = rows[("OpenCL exact", "xy")]
        ratio = f"{xy['mpixels_per_s'] / e16['mpixels_per_s']:.2f}x" if e16 else "-"
        print(f"| {r['name']} | {cell(('OpenCL exact', 'none'))} | {cell(('OpenCL exact', 'xy'))} | "
              f"{cell(('CPU reference', 'xy'))} | {cell(('Embree rtcIntersect1', '-'))} | "
              f"{cell(('Embree rtcIntersect16', '-'))} | {ratio} |")
    print("\nAccuracy of every variant against the double-precision reference (other triangle; relative "
          "depth error on same-triangle pixels: median / p99 / max)\n")
    print("| scene | variant | other triangle | hit/miss | depth error |")
    print("|---|---|---|---|---|")
    for r in reports:
        for x in r["rows"]:
            if x["fold"] not in ("none", "-"):
                continue  # fold modes give the same bits as none (exact builds) or near (fast)
            print(f"| {r['name']} | {x['variant']} | {100 * x['disagreeing_share']:.4f}% | "
                  f"{100 * x['hit_miss_share']:.4f}% | {x['depth_error_median']:.1e} / "
                  f"{x['depth_error_p99']:.1e} / {x['depth_error_max']:.1e} |")


def main():
    if len(sys.argv) < 2:
        sys.exit("usage: bench_tables.py REPORT.json...  |  bench_tables.py --peers REPORT-peers.json...")
    if sys.argv[1] == "--peers":
        peers_tables(sys.argv[2:])
        return
    reports = load(sys.argv[1:])
    r0 = reports[0]
    print(f"{r0['width']}x{r0['height']}, {r0['views']} views per scene, median of {r0['frames']} frames "
          f"after {r0['warmup']} warm-up; device: {r0['device']}.\n")
    print("Table 1 - render time T per frame (ray list + trace + readback; ratio: none / method) and device "
          "memory M\n")
    print(table1(reports))
    print("\nTable 2 - pre-build (all bottom-level trees, once) and update per frame (culling + top-level "
          "build + upload; ratio: method / none)\n")
    print(table2(reports))


if __name__ == "__main__":
    main()
