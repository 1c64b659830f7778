#!/usr/bin/python3
"""The mission's chart: speed against accuracy, every tracer measured against
the double-precision reference on the same random views. Left, pixels per
second (log) against the relative depth error (log; the marker at the largest
p99 of any view, the whisker up to the largest maximum); right, against the
share of pixels hitting another triangle than the reference. One marker per
variant at its fastest fold mode (fold modes give the same bits).

Filled markers: `rayfold-peers --json` (rayfold's variants and Embree, timed
in C++). Hollow markers, with --python: `tools/bench/bench_python.py --json`
(rayfold's Renderer.render, Mitsuba 3 and Open3D, wall clock from Python),
whose speeds compare with each other, not with the C++ ones. Writes PNG and
SVG.

Run with Debian's python3 (python3-matplotlib): /usr/bin/python3.
usage: tools/bench/chart_peers.py PEERS.json OUT_BASENAME [--python PYTHON.json]
"""
import json
import os
import sys

FLOOR = 1e-9  # where an error or share of exactly 0 is drawn (log axis)


def fastest_per_variant(rows):
    """Each variant's fastest row (fold modes of one variant share their accuracy)."""
    best = {}
    for row in rows:
        if row["variant"] not in best or row["mpixels_per_s"] > best[row["variant"]]["mpixels_per_s"]:
            best[row["variant"]] = row
    return list(best.values())


def points(peers, python):
    """(label, row, filled) for every tracer to draw."""
    out = []
    for row in fastest_per_variant(peers["rows"]):
        fold = f", fold {row['fold']}" if row.get("fold", "-") != "-" else ""
        out.append((f"{row['variant']}{fold}", row, True))
    if python:
        # rayfold's G-buffer renders (not its depth-only ones), each kind at its fastest fold.
        ours = {}
        for r in python["rows"]:
            if r["variant"].startswith("rayfold") and "channels=" not in r["variant"] and "depth_error_p99" in r:
                kind = r["variant"].rsplit(", fold", 1)[0]
                if kind not in ours or r["mpixels_per_s"] > ours[kind]["mpixels_per_s"]:
                    ours[kind] = r
        for best in ours.values():
            out.append((f"from Python: {best['variant']}", best, False))
        for row in python["rows"]:
            if not row["variant"].startswith("rayfold") and "depth_error_p99" in row:
                out.append((f"from Python: {row['variant']}", row, False))
    return out


def marker_for(label):
    if "Embree" in label:
        return "D"
    if "Mitsuba" in label:
        return "s"
    if "Open3D" in label:
        return "^"
    return "o"


def main():
    args = sys.argv[1:]
    python_path = None
    if "--python" in args:
        i = args.index("--python")
        if i + 1 >= len(args):
            sys.exit(__doc__)
        python_path = args[i + 1]
        del args[i:i + 2]
    if len(args) != 2:
        sys.exit(__doc__)
    with open(args[0]) as f:
        peers = json.load(f)
    python = None
    if python_path:
        with open(python_path) as f:
            python = json.load(f)
    drawn = points(peers, python)
    if not drawn:
        sys.exit(f"chart_peers.py: {args[0]}: no rows to draw")
    import matplotlib  # here, so that points() is testable without it
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    colours = plt.get_cmap("tab20").colors[::2] + plt.get_cmap("tab20").colors[1::2]
    fig, (left, right) = plt.subplots(1, 2, figsize=(14, 8), dpi=110, sharex=True)
    xs = []
    for k, (label, row, filled) in enumerate(drawn):
        colour = colours[k % len(colours)]
        x = row["mpixels_per_s"] * 1e6
        xs.append(x)
        face = colour if filled else "none"
        p99 = max(row["depth_error_p99"], FLOOR)
        worst = max(row["depth_error_max"], FLOOR)
        left.plot([x, x], [p99, worst], color=colour, lw=1, alpha=0.6, zorder=2)
        left.scatter([x], [worst], marker="_", color=colour, s=80, zorder=3)
        left.scatter([x], [p99], marker=marker_for(label), facecolors=face, edgecolors=colour, s=60, zorder=3,
                     label=label)
        right.scatter([x], [max(row["disagreeing_share"], FLOOR)], marker=marker_for(label), facecolors=face,
                      edgecolors=colour, s=60, zorder=3)
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_xlabel("pixels answered per second (log)")
    left.set_xlim(min(xs) / 1.5, max(xs) * 1.5)
    left.set_ylabel("relative depth error against the double reference (log): p99 marker, max whisker")
    right.set_ylabel("share of pixels hitting another triangle than the double reference (log)")
    fig.legend(loc="lower center", ncol=3, fontsize=8, frameon=False)
    name = os.path.basename(peers["scene"])
    source = " (hollow: from Python, wall clock)" if python else ""
    fig.suptitle(f"{name}: {peers['width']}x{peers['height']}, {peers['views']} views, {peers['threads']} threads"
                 f"{source}\n{peers['device']}", fontsize=9)
    fig.tight_layout(rect=(0, 0.03 * (1 + -(-len(drawn) // 3)), 1, 1))  # room for the legend rows
    for ext in ("png", "svg"):
        fig.savefig(f"{args[1]}.{ext}")


if __name__ == "__main__":
    main()
