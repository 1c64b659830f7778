#!/usr/bin/env python3
"""rayfold from Python against the Python ray casters a user would otherwise
pick: Mitsuba 3 (`llvm_ad_rgb`, `Scene.ray_intersect`) and Open3D
(`RaycastingScene.cast_rays`), on the same rays (the camera's
`ray_directions()` from its eye) and the same world-space triangles (every
instance's mesh through its transform), views from a camera list (the
`cameras` of a `rayfold-peers --json` report: random views).

Every peer's depth is checked against rayfold's on every view before anything
is timed (hit/miss and depth agreement); a peer that disagrees is reported and
not timed. Times are wall clock from Python after a warm-up, median over
frames, per view, then the median over views: rayfold's `Renderer.render`
(the whole G-buffer into numpy, every fold mode, the fastest reported; and
with channels="depth", the distances alone as the peers return them), the
peers' intersection call on prebuilt rays (ray building is not counted).

usage: bench_python.py SCENE --cameras PEERS.json [--size WxH] [--threads N]
                       [--frames N] [--warmup N] [--json OUT] [--md OUT]
Peers that are not installed are named and skipped (pip install mitsuba
open3d-cpu); exit 3 when a peer disagrees with rayfold.
"""
import argparse
import json
import os
import statistics
import sys
import time

import numpy as np

import rayfold

FOLDS = ("none", "y", "x", "xy")
# Agreement a peer must show before it is timed: the same rays through the
# same triangles differ only by float rounding (each tracer's own test) and
# at silhouettes where two triangles are within that rounding.
MIN_HIT_AGREEMENT = 0.995
MAX_MEDIAN_DEPTH_ERROR = 1e-5


def cameras_from(path, width, height):
    with open(path) as f:
        report = json.load(f)
    if "cameras" not in report or not report["cameras"]:
        sys.exit(f"bench_python.py: {path}: no 'cameras' list (write one with rayfold-peers --random-views K --json)")
    return [rayfold.Camera.look_at(c["eye"], c["look_at"], c["up"], c["vfov"], width, height) for c in report["cameras"]]


def timed(call, frames, warmup):
    for _ in range(warmup):
        call()
    times = []
    for _ in range(frames):
        t0 = time.perf_counter()
        out = call()
        times.append(1e3 * (time.perf_counter() - t0))
    return statistics.median(times), out


class Mitsuba:
    name = "Mitsuba 3 ray_intersect (llvm_ad_rgb)"

    def __init__(self, tris, threads):
        import drjit as dr
        import mitsuba as mi
        mi.set_variant("llvm_ad_rgb")
        dr.set_thread_count(threads)
        self.dr, self.mi = dr, mi
        mesh = mi.Mesh("all", vertex_count=3 * len(tris), face_count=len(tris))
        params = mi.traverse(mesh)
        params["vertex_positions"] = mi.Float(tris.reshape(-1).astype(np.float32))
        params["faces"] = mi.UInt32(np.arange(3 * len(tris), dtype=np.uint32))
        params.update()
        self.scene = mi.load_dict({"type": "scene", "mesh": mesh})

    def prepare(self, origin, dirs):
        mi = self.mi
        d = dirs.reshape(-1, 3)
        o = np.broadcast_to(origin, d.shape)
        ray = mi.Ray3f(mi.Point3f(*[mi.Float(np.ascontiguousarray(o[:, k])) for k in range(3)]),
                       mi.Vector3f(*[mi.Float(np.ascontiguousarray(d[:, k])) for k in range(3)]))
        return ray

    def cast(self, ray):
        si = self.scene.ray_intersect(ray)
        self.dr.eval(si.t)
        return np.asarray(si.t)


class Open3D:
    name = "Open3D RaycastingScene.cast_rays"

    def __init__(self, tris, threads):
        import open3d as o3d
        self.o3d = o3d
        self.scene = o3d.t.geometry.RaycastingScene(nthreads=threads)
        v = tris.reshape(-1, 3)
        f = np.arange(len(v), dtype=np.uint32).reshape(-1, 3)
        self.scene.add_triangles(o3d.core.Tensor(v), o3d.core.Tensor(f))

    def prepare(self, origin, dirs):
        d = dirs.reshape(-1, 3)
        rays = np.concatenate([np.broadcast_to(origin, d.shape), d], axis=1).astype(np.float32)
        return self.o3d.core.Tensor(rays)

    def cast(self, rays):
        return self.scene.cast_rays(rays)["t_hit"].numpy()


def agreement(ours, theirs):
    """Share of pixels where both hit or both miss, and the median relative
    depth difference where both hit."""
    a, b = np.isfinite(ours), np.isfinite(theirs)
    both = a & b
    rel = np.abs(theirs[both] - ours[both]) / ours[both] if both.any() else np.zeros(1)
    return float(np.mean(a == b)), float(np.median(rel))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--cameras", required=True)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--json")
    ap.add_argument("--md")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))

    scene = rayfold.Scene(args.scene)
    cams = cameras_from(args.cameras, width, height)
    renderer = rayfold.Renderer(scene, threads=args.threads)
    tris = scene.world_triangles().triangles

    peers, skipped = [], []
    for cls, pkg in ((Mitsuba, "mitsuba"), (Open3D, "open3d-cpu")):
        try:
            peers.append(cls(tris, args.threads))
        except ImportError as e:
            skipped.append(f"{cls.name}: cannot be imported ({e}); not timed (pip install {pkg})")

    ours_ms = {f: [] for f in FOLDS}
    depth_ms = {f: [] for f in FOLDS}
    peer_ms = {p.name: [] for p in peers}
    checks = {p.name: [] for p in peers}
    for cam in cams:
        depth = None
        for f in FOLDS:
            ms, g = timed(lambda: renderer.render(cam, fold=f), args.frames, args.warmup)
            ours_ms[f].append(ms)
            depth = g.depth.reshape(-1)
            ms, d = timed(lambda: renderer.render(cam, fold=f, channels="depth"), args.frames, args.warmup)
            depth_ms[f].append(ms)
            if not np.array_equal(d.depth.view(np.uint32), g.depth.view(np.uint32)):
                sys.exit(f"bench_python.py: channels='depth' changed the depth (fold {f}): a rayfold bug")
        origin = np.asarray(cam.eye, dtype=np.float32)
        dirs = np.asarray(cam.ray_directions(), dtype=np.float32)
        for p in peers:
            rays = p.prepare(origin, dirs)
            hit, err = agreement(depth, p.cast(rays))
            checks[p.name].append((hit, err))
            if hit >= MIN_HIT_AGREEMENT and err <= MAX_MEDIAN_DEPTH_ERROR:
                ms, _ = timed(lambda: p.cast(rays), args.frames, args.warmup)
                peer_ms[p.name].append(ms)

    best_fold = min(FOLDS, key=lambda f: statistics.median(ours_ms[f]))
    ours = statistics.median(ours_ms[best_fold])
    ours_depth = min(statistics.median(depth_ms[f]) for f in FOLDS)
    mpix = width * height / 1e3
    rows = [{"variant": f"rayfold Renderer.render, fold {f}", "ms": statistics.median(ours_ms[f]),
             "mpixels_per_s": mpix / statistics.median(ours_ms[f])} for f in FOLDS]
    rows += [{"variant": f"rayfold Renderer.render, channels='depth', fold {f}", "ms": statistics.median(depth_ms[f]),
              "mpixels_per_s": mpix / statistics.median(depth_ms[f])} for f in FOLDS]
    failed = []
    for p in peers:
        worst_hit = min(h for h, _ in checks[p.name])
        worst_err = max(e for _, e in checks[p.name])
        if len(peer_ms[p.name]) < len(cams):
            failed.append(f"{p.name}: disagrees with rayfold (worst view: hit/miss agreement {worst_hit:.4f}, "
                          f"median depth difference {worst_err:.1e}); not timed")
            continue
        ms = statistics.median(peer_ms[p.name])
        rows.append({"variant": p.name, "ms": ms, "mpixels_per_s": mpix / ms, "ratio": ms / ours,
                     "ratio_depth_only": ms / ours_depth, "hit_agreement": worst_hit,
                     "median_depth_difference": worst_err})

    name = os.path.splitext(os.path.basename(args.scene))[0]
    lines = [f"Scene `{name}`: {len(tris)} triangles; {width}x{height}, {len(cams)} views from {args.cameras}, "
             f"median of {args.frames} frames after {args.warmup}, {args.threads} threads, wall clock from Python.",
             "", "| variant | ms/frame | Mpixels/s | rayfold's fastest fold against it: G-buffer | depth only |",
             "|---|---|---|---|---|"]
    for r in rows:
        ratio = f"**{r['ratio']:.2f}x**" if "ratio" in r else ""
        ratio_depth = f"**{r['ratio_depth_only']:.2f}x**" if "ratio_depth_only" in r else ""
        lines.append(f"| {r['variant']} | {r['ms']:.1f} | {r['mpixels_per_s']:.1f} | {ratio} | {ratio_depth} |")
    for note in skipped + failed:
        lines.append(f"\n{note}")
    md = "\n".join(lines) + "\n"
    print(md)
    if args.md:
        with open(args.md, "w") as f:
            f.write(md)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"scene": name, "width": width, "height": height, "views": len(cams), "frames": args.frames,
                       "threads": args.threads, "fastest_fold": best_fold, "rows": rows, "skipped": skipped,
                       "failed": failed}, f, indent=1)
    return 3 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
