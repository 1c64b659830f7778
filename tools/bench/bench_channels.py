#!/usr/bin/env python3
"""What the G-buffer's resolved channels cost over the visibility buffer, from
Python, per channel set, on a camera list's views (the `cameras` of a
`rayfold-peers --random-views K --json` report: random views), issue 49's
part 6 table.

Each set's row also gives the MB of planes it writes beyond the visibility buffer's (at
1280x720 the resolve's floor is that write: memory bandwidth, docs/results.md).

Every view's every channel set is first checked: its planes rendered folded
(fold xy where the camera allows) equal the unfolded render's bit for bit,
flow included (to the same camera moved sideways by 1% of the scene's size).
Then the channel sets take turns frame by frame (one warm-up round), so that
a noisy machine's drift hits them alike; per view the median frame of each
set, less the visibility buffer's, and its ratio to the trace's own time;
reported as the median over views. The first render that reads the
materials' attributes and images is timed once per run (a fresh Scene).

usage: bench_channels.py SCENE --cameras PEERS.json [--size WxH] [--frames N] [--json OUT]
"""
import argparse
import json
import os
import statistics
import sys
import time

import numpy as np
import rayfold

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_python import cameras_from, machine_info  # noqa: E402

SETS = {
    "visibility": "depth,normal,barycentrics,instance_id,primitive_id",
    "depth, ids, shading normal": "depth,instance_id,primitive_id,shading_normal",
    "materials": "instance_id,base_color,metallic_roughness,emissive",
    "position": "depth,instance_id,position",
    "texcoord": "depth,instance_id,texcoord",
    "tangent frame": "depth,instance_id,shading_normal,tangent,mapped_normal",
    "every channel but flow": "depth,normal,barycentrics,instance_id,primitive_id,shading_normal,texcoord,"
                              "texcoord1,position,object_position,material_id,base_color,metallic_roughness,"
                              "emissive,label,tangent,mapped_normal",
    "flow": "depth,instance_id,flow",
    "flow_visible": "depth,instance_id,flow_visible",
}
VISIBILITY = set(SETS["visibility"].split(","))


def moved(scene, camera):
    """The camera moved sideways by 1% of the scene's size: the flow's other view."""
    b = scene.bounds
    step = np.eye(4)
    step[0, 3] = 0.01 * np.linalg.norm(np.array(b[3:]) - np.array(b[:3]))
    fx, fy, cx, cy = camera.intrinsics
    return rayfold.Camera.from_matrix(np.array(camera.camera_to_world) @ step, fx, fy, cx, cy, camera.width,
                                      camera.height, convention="opengl")


def render(scene, camera, channels, fold, other):
    if "flow" in channels:
        return scene.render(camera, fold=fold, channels=channels, flow_to=other)
    return scene.render(camera, fold=fold, channels=channels)


def check(scene, camera, other, fold):
    """Every set's planes folded equal unfolded, bit for bit; exits naming the first that differs."""
    for name, channels in SETS.items():
        a, b = render(scene, camera, channels, "none", other), render(scene, camera, channels, fold, other)
        for plane in channels.split(","):
            x, y = getattr(a, plane), getattr(b, plane)
            if x.tobytes() != y.tobytes():
                sys.exit(f"bench_channels.py: {name}: plane {plane} folded ({fold}) differs from unfolded")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--cameras", required=True)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--frames", type=int, default=7)
    ap.add_argument("--json")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    first_scene = rayfold.Scene(args.scene)
    cameras = cameras_from(args.cameras, width, height)
    first_scene.render(cameras[0], channels="depth")
    t1 = time.perf_counter()
    first_scene.render(cameras[0], channels=SETS["materials"])
    first_material_ms = 1e3 * (time.perf_counter() - t1)
    scene = rayfold.Scene(args.scene)
    written = {}  # MB of planes a set writes beyond the visibility buffer's, per frame
    per_view = {name: [] for name in SETS}
    ratio = {name: [] for name in SETS}
    traces = []
    for camera in cameras:
        fold = "xy" if camera.can_fold_columns and camera.can_fold_rows else "none"
        other = moved(scene, camera)
        check(scene, camera, other, fold)
        times = {name: [] for name in SETS}
        for frame in range(args.frames + 1):
            for name, channels in SETS.items():
                start = time.perf_counter()
                g = render(scene, camera, channels, fold, other)
                if frame > 0:
                    times[name].append(1e3 * (time.perf_counter() - start))
                if name == "visibility" and frame > 0:
                    traces.append(g.trace_ms)
                written[name] = sum(getattr(g, p).nbytes for p in channels.split(",") if p not in VISIBILITY) / 1e6
        base = statistics.median(times["visibility"])
        trace = statistics.median(traces[-args.frames:])
        for name in SETS:
            extra = statistics.median(times[name]) - base
            per_view[name].append(base if name == "visibility" else extra)
            ratio[name].append(extra / trace)
    report = {
        "scene": os.path.basename(args.scene),
        "views": len(cameras),
        "size": args.size,
        "machine": machine_info(),
        "trace_ms": statistics.median(traces),
        "first_material_render_ms": first_material_ms,
        "sets": {name: {"ms": statistics.median(per_view[name]), "of_trace": statistics.median(ratio[name]),
                        "written_mb": written[name]} for name in SETS},
    }
    print(f"{report['scene']}, {len(cameras)} views, {args.size}: trace {report['trace_ms']:.1f} ms, visibility "
          f"frame {report['sets']['visibility']['ms']:.1f} ms; first material render {first_material_ms:.0f} ms")
    for name in list(SETS)[1:]:
        s = report["sets"][name]
        print(f"  + {name}: {s['ms']:+.1f} ms ({s['of_trace']:.2f}x the trace; {s['written_mb']:.1f} MB of planes "
              "beyond the visibility buffer's)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)


if __name__ == "__main__":
    main()
