"""The frame against the trace: what a streamed view costs beyond its trace,
by readback. For each scene, random views (bench_batch's generator) go
through Scene.render_views a few at a time, as iter_views and the batch
workers send them, once with the host layout (every pixel's 32-byte hit
info, RAYFOLD_READBACK=hits) and once packed (only the planes asked for,
packed on the device, passes pipelined: what every device but a CPU one
does, RAYFOLD_READBACK=packed), for every channel set. Each packed G-buffer
is checked bit for bit against the host layout's before anything is
reported. Reported: views per second, Gpixels per second end to end, and
frame / trace: the wall time per view over the kernel's time (1.0: the
host work and the readback hide behind the trace entirely).

On PoCL both layouts run on the same two cores, so the packed one has
nothing to overlap with and pays its pack kernel; the figure that matters
is a GPU's (run it where RAYFOLD_CL_DEVICE names one).

usage: bench_readback.py [SCENE ...] [--views N] [--size 1280x720] [--chunk K] [--json FILE]"""
import argparse
import json
import os
import pathlib
import statistics
import sys
import time

import numpy as np

import rayfold
from bench_batch import default_scenes, random_views

CHANNEL_SETS = (None, "depth,instance_id")
PLANES = ("depth", "normal", "uv", "instance_id", "primitive_id")


def render_all(scene, cameras, chunk, channels):
    """Every view through render_views, chunk views a call; the G-buffers,
    the wall time and the sum of the views' trace times."""
    out, trace_ms = [], 0.0
    t0 = time.perf_counter()
    for k in range(0, len(cameras), chunk):
        for g in scene.render_views(cameras[k:k + chunk], align=1, channels=channels):
            trace_ms += g.trace_ms
            out.append(g)
    return out, (time.perf_counter() - t0) * 1e3, trace_ms


def same_planes(a, b):
    for name in PLANES:
        x, y = getattr(a, name), getattr(b, name)
        if (x is None) != (y is None):
            return f"{name} present in one only"
        if x is not None and x.tobytes() != y.tobytes():
            return f"{name} differs"
    return "" if a.hits == b.hits else f"hits {a.hits} vs {b.hits}"


def load(path, readback):
    # Renderers read RAYFOLD_READBACK when made; each Scene keeps its own.
    os.environ["RAYFOLD_READBACK"] = readback
    scene = rayfold.Scene(str(path))
    scene.render(scene.default_camera(64, 48))  # trees and kernels, outside the timing
    return scene


def bench_scene(path, views, width, height, chunk, repeats):
    path = pathlib.Path(path)
    cameras = random_views(rayfold.Scene(str(path)), views, width, height, seed=7)
    scenes = {mode: load(path, mode) for mode in ("hits", "packed")}
    os.environ.pop("RAYFOLD_READBACK", None)
    rows = []
    for channels in CHANNEL_SETS:
        results = {}
        for mode, scene in scenes.items():
            render_all(scene, cameras[:chunk], chunk, channels)  # warm-up
            walls, traces = [], []
            for _ in range(repeats):
                gs, wall, trace = render_all(scene, cameras, chunk, channels)
                walls.append(wall)
                traces.append(trace)
            results[mode] = (gs, statistics.median(walls), statistics.median(traces))
        for v, (a, b) in enumerate(zip(results["hits"][0], results["packed"][0])):
            why = same_planes(a, b)
            if why:
                sys.exit(f"{path.name}: view {v}, channels {channels}: the packed readback's {why}")
        for mode, (_, wall, trace) in results.items():
            rows.append({
                "scene": path.stem, "channels": channels or "all", "readback": mode,
                "views_per_s": views / (wall / 1e3),
                "gpix_per_s": views * width * height / (wall / 1e3) / 1e9,
                "frame_over_trace": wall / trace if trace > 0 else float("nan"),
                "wall_ms_per_view": wall / views, "trace_ms_per_view": trace / views,
            })
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", type=pathlib.Path)
    ap.add_argument("--views", type=int, default=24)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--chunk", type=int, default=8, help="views per render_views call (iter_views: 32)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--json", type=pathlib.Path)
    a = ap.parse_args()
    width, height = (int(x) for x in a.size.split("x"))
    scenes = a.scenes or default_scenes()
    device = rayfold.Renderer(rayfold.Scene(str(scenes[0]))).device_name
    print(f"# {a.views} random views at {a.size}, {a.chunk} per call, median of {a.repeats}; {device}")
    print(f"{'scene':18} {'channels':18} {'readback':8} {'views/s':>8} {'Gpix/s':>7} {'ms/view':>8} "
          f"{'trace ms':>8} {'frame/trace':>11}")
    rows = []
    for path in scenes:
        for r in bench_scene(path, a.views, width, height, a.chunk, a.repeats):
            rows.append(r)
            print(f"{r['scene']:18} {r['channels']:18} {r['readback']:8} {r['views_per_s']:8.1f} "
                  f"{r['gpix_per_s']:7.3f} {r['wall_ms_per_view']:8.2f} {r['trace_ms_per_view']:8.2f} "
                  f"{r['frame_over_trace']:11.2f}", flush=True)
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
