"""Views per second, one process against rayfold-batch on Ray: for each scene
and size, the same random views rendered and written as EXRs by
Scene.iter_views + GBuffer.write_exr in this process, then by
rayfold.batch.render with 1 and 2 workers (a local cluster each time; its
start and the workers' scene loads are reported apart, as the time to the
workers' start: from Ray up to every worker ready to render, its trees
and kernels built, each worker loading the file and building its own and,
last, with the trees built once and sent through Ray's object store). Every batch output is checked bit for bit against the
single-process render before anything is reported.

usage: bench_batch.py [SCENE ...] [--views N] [--sizes 640x480,1280x720] [--workers 1,2] [--json FILE]
SCENE defaults to the bundled atrium and every .glb in $RAYFOLD_SCENES
(default ../shared/scenes)."""
import argparse
import json
import math
import os
import pathlib
import random
import shutil
import sys
import tempfile
import time

import rayfold
import rayfold.batch

ROOT = pathlib.Path(__file__).resolve().parents[2]
PLANES = ("depth", "normal", "uv", "instance_id", "primitive_id")


def default_scenes():
    scenes = [ROOT / "scenes" / "atrium.glb"]
    shared = pathlib.Path(os.environ.get("RAYFOLD_SCENES", ROOT.parent / "shared" / "scenes"))
    if shared.is_dir():
        scenes += sorted(shared.glob("*.glb"))
    else:
        print(f"note: {shared} is absent (RAYFOLD_SCENES): the bundled scene only", file=sys.stderr)
    return scenes


def random_views(scene, count, width, height, seed):
    """Eyes on a sphere around the scene's bounds looking at points near its
    centre: views nobody chose."""
    lo, hi = scene.bounds[:3], scene.bounds[3:]
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    radius = max(b - a for a, b in zip(lo, hi))
    rng = random.Random(seed)
    cams = []
    while len(cams) < count:
        z, phi = rng.uniform(-0.3, 0.9), rng.uniform(0, 2 * math.pi)
        r = radius * rng.uniform(0.6, 1.2)
        d = (math.sqrt(1 - z * z) * math.cos(phi), z, math.sqrt(1 - z * z) * math.sin(phi))
        eye = tuple(c + r * v for c, v in zip(centre, d))
        target = tuple(c + radius * rng.uniform(-0.1, 0.1) for c in centre)
        cams.append(rayfold.Camera.look_at(eye, target, (0, 1, 0), rng.uniform(40, 70), width, height))
    return cams


def single_process(scene, cameras, folder, fold):
    """Views per second of iter_views with each view written as an EXR, after
    a warm-up view (trees and kernels built)."""
    scene.render(cameras[0], fold=fold)
    t0 = time.perf_counter()
    for i, g in enumerate(scene.iter_views(cameras, fold=fold)):
        g.write_exr(os.path.join(folder, f"v_{i:05d}.exr"), scene)
    return len(cameras) / (time.perf_counter() - t0)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scenes", nargs="*")
    p.add_argument("--views", type=int, default=64)
    p.add_argument("--sizes", default="640x480,1280x720")
    p.add_argument("--workers", default="1,2")
    p.add_argument("--fold", default="xy")
    p.add_argument("--seed", type=int, default=11)
    p.add_argument("--json", help="also write the rows as JSON")
    a = p.parse_args()
    scenes = [pathlib.Path(s) for s in a.scenes] or default_scenes()
    sizes = [tuple(int(v) for v in s.split("x")) for s in a.sizes.split(",")]
    worker_counts = [int(w) for w in a.workers.split(",")]
    rows = []
    print("| scene | size | one process views/s | " + " | ".join(
        f"{w} worker{'s' if w > 1 else ''} views/s (x) | worker start s" for w in worker_counts) +
        " | worker start s, trees sent |")
    print("|---|---|---|" + "---|---|" * len(worker_counts) + "---|")
    for path in scenes:
        scene = rayfold.Scene(str(path))
        for width, height in sizes:
            cameras = random_views(scene, a.views, width, height, a.seed)
            work = tempfile.mkdtemp(prefix="rayfold_bench_batch_")
            try:
                os.makedirs(os.path.join(work, "one"))
                one = single_process(scene, cameras, os.path.join(work, "one"), a.fold)
                row = {"scene": path.name, "width": width, "height": height, "views": a.views,
                       "one_process_views_per_second": one, "batch": []}
                cells = []
                for w in worker_counts:
                    out = os.path.join(work, f"w{w}")
                    os.makedirs(out)
                    s = rayfold.batch.render(str(path), cameras, os.path.join(out, "v_%05d.exr"), workers=w,
                                             fold=a.fold, progress=False)
                    if s.failed or s.rendered != a.views:
                        sys.exit(f"{path.name} {width}x{height}, {w} workers: {s.line()}")
                    for i in range(a.views):  # validate before reporting
                        got = rayfold.read_exr(os.path.join(out, f"v_{i:05d}.exr"))
                        want = rayfold.read_exr(os.path.join(work, "one", f"v_{i:05d}.exr"))
                        for plane in PLANES:
                            if got[plane].tobytes() != want[plane].tobytes():
                                sys.exit(f"{path.name} {width}x{height}, {w} workers: view {i} {plane} differs")
                    row["batch"].append({"workers": w, "views_per_second": s.views_per_second,
                                         "startup_seconds": s.startup_seconds,
                                         "worker_start_seconds": s.startup_seconds - s.cluster_seconds,
                                         "worker_peak_rss_mb": s.worker_peak_rss_mb})
                    cells.append(f"{s.views_per_second:.1f} ({s.views_per_second / one:.2f}x) | "
                                 f"{s.startup_seconds - s.cluster_seconds:.1f}")
                # A worker's start when the driver builds the trees and sends them through the object store.
                out = os.path.join(work, "trees")
                os.makedirs(out)
                s = rayfold.batch.render(str(path), cameras[:2], os.path.join(out, "v_%05d.exr"), workers=1,
                                         fold=a.fold, progress=False, send="trees")
                row["startup_seconds_trees"] = s.startup_seconds
                row["worker_start_seconds_trees"] = s.startup_seconds - s.cluster_seconds
                cells.append(f"{s.startup_seconds - s.cluster_seconds:.1f}")
                rows.append(row)
                print(f"| {path.name} | {width}x{height} | {one:.1f} | " + " | ".join(cells) + " |", flush=True)
            finally:
                shutil.rmtree(work, ignore_errors=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
