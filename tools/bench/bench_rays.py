#!/usr/bin/env python3
"""Ray queries from Python: rayfold's `scene.intersect` against Open3D
(`RaycastingScene.cast_rays`) and Mitsuba 3 (`Scene.ray_intersect`,
`llvm_ad_rgb`) on the same rays and world-space triangles (issue 21's
targets: at least 2x Open3D and 1x Mitsuba).

Two workloads: `incoherent`, N rays from origins uniform in the scene's
bounds along uniform directions; `camera`, every pixel's ray of each view of
a camera list (the `cameras` of a `rayfold-peers --json` report) passed as an
array. Every peer's t is checked against rayfold's first (hit/miss agreement
and median relative difference, as bench_python.py); a peer that disagrees is
reported and not timed. Wall clock from Python after a warm-up, median over
repeats; the peers' calls on prebuilt rays, rayfold's on numpy arrays
(checking and converting them included), once for every field (as the peers
return them) and once with channels="t" (t alone, its bits checked against
the full query's).

usage: bench_rays.py SCENE [--rays N] [--seed S] [--cameras PEERS.json] [--size WxH]
                     [--backend opencl|cpu] [--threads N] [--frames N] [--warmup N] [--json OUT]
Exit 3 when a peer disagrees with rayfold.
"""
import argparse
import json
import os
import statistics
import sys

import numpy as np

import rayfold
from bench_python import (MAX_MEDIAN_DEPTH_ERROR, MIN_HIT_AGREEMENT, Mitsuba, Open3D, agreement, cameras_from,
                          machine_info, timed)


def incoherent_rays(scene, n, seed):
    """Origins uniform in the bounds, directions uniform on the sphere."""
    rng = np.random.default_rng(seed)
    b = np.asarray(scene.bounds, dtype=np.float64)
    o = rng.uniform(b[:3], b[3:], size=(n, 3)).astype(np.float32)
    d = rng.normal(size=(n, 3))
    d = (d / np.linalg.norm(d, axis=1, keepdims=True)).astype(np.float32)
    return o, d


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--rays", type=int, default=1_000_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--cameras")
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--backend", default="opencl")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--json")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))

    scene = rayfold.Scene(args.scene)
    tris = scene.world_triangles().triangles
    peers, notes = [], []
    for cls, pkg in ((Open3D, "open3d-cpu"), (Mitsuba, "mitsuba")):
        try:
            peers.append(cls(tris, args.threads))
        except ImportError as e:
            notes.append(f"{cls.name}: cannot be imported ({e}); not timed (pip install {pkg})")

    workloads = [("incoherent", *incoherent_rays(scene, args.rays, args.seed))]
    if args.cameras:
        for i, cam in enumerate(cameras_from(args.cameras, width, height)):
            d = np.asarray(cam.ray_directions(), dtype=np.float32).reshape(-1, 3)
            o = np.ascontiguousarray(np.broadcast_to(np.asarray(cam.eye, dtype=np.float32), d.shape))
            # rayfold gets them as the image they are, (H, W, 3), as
            # camera.ray_directions() gives them (it then traces 16x16
            # blocks); the peers the same rays flat.
            workloads.append((f"camera view {i}", o, d, (height, width, 3)))

    def ours(o, d, shape, channels=None):
        return scene.intersect(o.reshape(shape), d.reshape(shape), backend=args.backend, threads=args.threads,
                               channels=channels)["t"].reshape(-1)

    rows, failed = [], []
    for name, o, d, *shape in workloads:
        shape = shape[0] if shape else o.shape
        ms, t = timed(lambda: ours(o, d, shape), args.frames, args.warmup)
        ms_t, t_only = timed(lambda: ours(o, d, shape, "t"), args.frames, args.warmup)
        if not np.array_equal(t.view(np.uint32), t_only.view(np.uint32)):
            sys.exit(f"bench_rays.py: channels='t' changed t on {name}: a rayfold bug")
        row = {"workload": name, "rays": len(o), "rayfold_ms": ms, "rayfold_mrays_per_s": len(o) / 1e3 / ms,
               "rayfold_t_only_ms": ms_t, "hit_share": float(np.isfinite(t).mean())}
        for p in peers:
            rays = p.prepare(o, d)
            hit, err = agreement(t, p.cast(rays).reshape(-1))
            if hit < MIN_HIT_AGREEMENT or err > MAX_MEDIAN_DEPTH_ERROR:
                failed.append(f"{p.name} on {name}: hit/miss agreement {hit:.4f}, median t difference {err:.1e}; "
                              "not timed")
                continue
            pms, _ = timed(lambda: p.cast(rays), args.frames, args.warmup)
            row[p.name] = {"ms": pms, "ratio": pms / ms, "ratio_t_only": pms / ms_t, "hit_agreement": hit,
                           "median_t_difference": err}
        rows.append(row)

    scene_name = os.path.splitext(os.path.basename(args.scene))[0]
    names = [p.name for p in peers]
    machine = machine_info()
    print(f"Scene `{scene_name}`: {len(tris)} triangles; rayfold scene.intersect ({args.backend}), "
          f"{args.threads} threads, median of {args.frames} after {args.warmup}, wall clock from Python. "
          "Ratio: the peer's time over rayfold's, every field (as the peers return them); then t alone.")
    print(f"Machine: {machine['cpu']} ({machine['isa']})" +
          "".join(f"; {k} {v}" for k, v in machine["peers"].items()) + ".\n")
    print("| workload | rays | hits | rayfold ms (Mrays/s) | t only ms | " +
          " | ".join(f"{n} ms (ratio; t only)" for n in names) + " |")
    print("|---|---|---|---|---|" + "---|" * len(names))
    for r in rows:
        cells = [f"{r[n]['ms']:.1f} (**{r[n]['ratio']:.2f}x**; {r[n]['ratio_t_only']:.2f}x)" if n in r else "-"
                 for n in names]
        print(f"| {r['workload']} | {r['rays']} | {100 * r['hit_share']:.0f}% | {r['rayfold_ms']:.1f} "
              f"({r['rayfold_mrays_per_s']:.1f}) | {r['rayfold_t_only_ms']:.1f} | " + " | ".join(cells) + " |")
    for note in notes + failed:
        print(f"\n{note}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"scene": scene_name, "machine": machine, "backend": args.backend, "threads": args.threads,
                       "frames": args.frames, "rows": rows, "notes": notes, "failed": failed}, f, indent=1)
    return 3 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
