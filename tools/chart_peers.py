#!/usr/bin/python3
"""Charts a `rayfold-peers --json` report: pixels per second (log) against
the share of pixels that disagree with the double-precision reference (log),
one labelled marker per variant and fold mode. Writes PNG and SVG.

Run with Debian's python3 (python3-matplotlib): /usr/bin/python3.
usage: tools/chart_peers.py REPORT.json OUT_BASENAME
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    "OpenCL exact": ("o", "tab:blue"),
    "OpenCL fast": ("s", "tab:orange"),
    "CPU reference": ("^", "tab:green"),
    "Embree rtcIntersect1": ("D", "tab:red"),
    "Embree rtcIntersect16": ("P", "tab:purple"),
}
FLOOR = 1e-6  # where a share of exactly 0 is drawn (log axis)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with open(sys.argv[1]) as f:
        report = json.load(f)
    fig, ax = plt.subplots(figsize=(9, 6), dpi=110)
    seen = set()
    xs, ys = [], []
    for i, row in enumerate(report["rows"]):
        marker, colour = STYLE.get(row["variant"], ("x", "black"))
        x = row["mpixels_per_s"] * 1e6
        y = max(row["disagreeing_share"], FLOOR)
        xs.append(x)
        ys.append(y)
        label = row["variant"] if row["variant"] not in seen else None
        seen.add(row["variant"])
        ax.scatter([x], [y], marker=marker, color=colour, s=60, zorder=3, label=label)
        if row["fold"] != "-":  # fold modes of one variant share a y: stagger their labels
            ax.annotate(row["fold"], (x, y), textcoords="offset points", xytext=(5, 6 + 9 * (i % 4)),
                        fontsize=8, color=colour)
    ax.set_xscale("log")
    ax.set_yscale("log")
    # At least a decade on each axis, so log ticks stay readable.
    ax.set_xlim(min(xs) / 2, max(xs) * 2)
    ax.set_ylim(min(ys) / 3, max(ys) * 3)
    ax.legend(loc="upper left", fontsize=8)
    ax.set_xlabel("pixels answered per second (log)")
    ax.set_ylabel("share of pixels hitting another triangle than the double reference (log)")
    name = os.path.basename(report["scene"])
    ax.set_title(f"{name}: {report['width']}x{report['height']}, {report['views']} views, "
                 f"{report['threads']} threads\n{report['device']}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    for ext in ("png", "svg"):
        fig.savefig(f"{sys.argv[2]}.{ext}")


if __name__ == "__main__":
    main()
