#!/usr/bin/env python3
"""rayfold from Python against the Python ray casters a user would otherwise
pick: Mitsuba 3 (`llvm_ad_rgb`, `Scene.ray_intersect`) and Open3D
(`RaycastingScene.cast_rays`), on the same rays (the camera's
`ray_directions()` from its eye) and the same world-space triangles (every
instance's mesh through its transform), views from a camera list (the
`cameras` of a `rayfold-peers --json` report: random views).

Every peer's depth is checked against rayfold's on every view before anything
is timed (hit/miss and depth agreement); a peer that disagrees is reported and
not timed. Every tracer's hits, rayfold's included, are then measured against
the double-precision reference (Scene.render_reference), as rayfold-peers
measures its own variants and Embree: the share of pixels on another triangle
and the relative depth error on the reference's triangle (median over views of
the medians, the largest p99 and maximum of any view), so that
tools/bench/chart_peers.py can put Mitsuba and Open3D on the chart of speed against
accuracy. Times are wall clock from Python after a warm-up, median over
frames, per view, then the median over views: rayfold's `Renderer.render`
(the whole G-buffer into numpy, every fold mode, the fastest reported; with
channels="depth", the distances alone as the peers return them; and with
exact_depth=True, its depth within 2^-24 of the exact distance), the
peers' intersection call on prebuilt rays (ray building is not counted).

The first G-buffer of the first view is also timed in fresh processes (the
median of --first-runs, alternated): rayfold's Scene load, Renderer and first
render, against each peer's scene build and first intersection call (its rays
made from the same triangles and directions; the import not counted on either
side, the peers' glTF loading not counted, rayfold's is).

usage: bench_python.py SCENE --cameras PEERS.json [--size WxH] [--threads N]
                       [--frames N] [--warmup N] [--first-runs N] [--json OUT]
                       [--md OUT]
Peers that are not installed are named and skipped (pip install mitsuba
open3d-cpu); exit 3 when a peer disagrees with rayfold.
"""
import argparse
import json
import os
import statistics
import subprocess
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

    def hits(self, ray):
        """t and the row of world_triangles hit (-1 on a miss)."""
        si = self.scene.ray_intersect(ray)
        self.dr.eval(si.t, si.prim_index)
        t = np.asarray(si.t)
        return t, np.where(np.isfinite(t), np.asarray(si.prim_index).astype(np.int64), -1)


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

    def hits(self, rays):
        """t and the row of world_triangles hit (-1 on a miss)."""
        out = self.scene.cast_rays(rays)
        t = out["t_hit"].numpy()
        return t, np.where(np.isfinite(t), out["primitive_ids"].numpy().astype(np.int64), -1)


def agreement(ours, theirs):
    """Share of pixels where both hit or both miss, and the median relative
    depth difference where both hit."""
    a, b = np.isfinite(ours), np.isfinite(theirs)
    both = a & b
    rel = np.abs(theirs[both] - ours[both]) / ours[both] if both.any() else np.zeros(1)
    return float(np.mean(a == b)), float(np.median(rel))


def accuracy(reference, depth, instance_id, primitive_id):
    """One view's hits (flat arrays; MISS ids on a miss) against the double
    reference (Scene.render_reference), as rayfold-peers measures (host/
    reference/accuracy.cpp): the share of pixels whose (instance, primitive)
    differs, the share where one hits and the other misses, and the median,
    p99 and maximum relative depth error where both hit the same triangle."""
    ref_inst = reference["instance_id"].reshape(-1)
    ref_prim = reference["primitive_id"].reshape(-1)
    ref_depth = reference["depth"].reshape(-1)
    same = (ref_inst == instance_id) & (ref_prim == primitive_id)
    ref_hit, hit = ref_inst != rayfold.MISS, instance_id != rayfold.MISS
    out = {"disagreeing_share": 1.0 - float(np.mean(same)), "hit_miss_share": float(np.mean(ref_hit != hit)),
           "depth_error_median": 0.0, "depth_error_p99": 0.0, "depth_error_max": 0.0}
    both = same & ref_hit
    if both.any():
        err = np.sort(np.abs(depth[both].astype(np.float64) - ref_depth[both]) / ref_depth[both])
        out["depth_error_median"] = float(err[len(err) // 2])
        out["depth_error_p99"] = float(err[min(len(err) - 1, int(0.99 * len(err)))])
        out["depth_error_max"] = float(err[-1])
    return out


def over_views(per_view):
    """rayfold-peers' summary of views: shares averaged, the median of the
    median errors (the upper middle one of an even count, as core::median),
    the largest p99 and maximum."""
    return {"disagreeing_share": statistics.mean(a["disagreeing_share"] for a in per_view),
            "hit_miss_share": statistics.mean(a["hit_miss_share"] for a in per_view),
            "depth_error_median": statistics.median_high(a["depth_error_median"] for a in per_view),
            "depth_error_p99": max(a["depth_error_p99"] for a in per_view),
            "depth_error_max": max(a["depth_error_max"] for a in per_view)}


def peer_ids(world, rows):
    """(instance_id, primitive_id) of world_triangles rows; MISS for -1."""
    hit = rows >= 0
    inst = np.full(len(rows), rayfold.MISS, dtype=np.uint32)
    prim = np.full(len(rows), rayfold.MISS, dtype=np.uint32)
    inst[hit] = world.instance_id[rows[hit]]
    prim[hit] = world.primitive_id[rows[hit]]
    return inst, prim


PEER_CLASSES = {"mitsuba": Mitsuba, "open3d": Open3D}


def machine_info(renderer=None):
    """The machine the figures are from, as rayfold-peers names it (tools/bench/machine_info.h): the CPU's model and
    widest vector ISA from /proc/cpuinfo, rayfold's OpenCL device and tile lanes (with a renderer), the peers'
    versions."""
    cpu, flags = "unknown CPU", set()
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() == "model name" and cpu == "unknown CPU":
                    cpu = value.strip()
                elif key.strip() == "flags" and not flags:
                    flags = set(value.split())
    except OSError:
        pass
    isa = next((name for flag, name in (("avx512f", "AVX-512"), ("avx2", "AVX2"), ("avx", "AVX"),
                                        ("sse4_2", "SSE4.2")) if flag in flags), "unknown ISA")
    peers = {}
    for module in ("mitsuba", "open3d"):
        try:
            peers[module] = __import__(module).__version__
        except Exception:  # a peer that cannot be imported is reported as skipped elsewhere
            pass
    out = {"cpu": cpu, "isa": isa, "peers": peers}
    if renderer is not None:
        out.update(opencl_device=renderer.device_name, tile_lanes=renderer.tile_lanes)
    return out


def first_gbuffer_child(args, who, width, height):
    """One fresh process's first G-buffer of the first view, printed as JSON
    (ms): rayfold's load, renderer and first frame, or a peer's scene build
    and first intersection call."""
    cam = cameras_from(args.cameras, width, height)[0]
    if who == "rayfold":
        t0 = time.perf_counter()
        scene = rayfold.Scene(args.scene)
        t1 = time.perf_counter()
        renderer = rayfold.Renderer(scene, threads=args.threads)
        t2 = time.perf_counter()
        renderer.render(cam)
        t3 = time.perf_counter()
        out = {"load": 1e3 * (t1 - t0), "renderer": 1e3 * (t2 - t1), "frame": 1e3 * (t3 - t2)}
    else:
        tris = rayfold.Scene(args.scene).world_triangles().triangles
        origin = np.asarray(cam.eye, dtype=np.float32)
        dirs = np.asarray(cam.ray_directions(), dtype=np.float32)
        t0 = time.perf_counter()
        peer = PEER_CLASSES[who](tris, args.threads)
        peer.cast(peer.prepare(origin, dirs))
        out = {"build_and_first_call": 1e3 * (time.perf_counter() - t0)}
    out["total"] = sum(out.values())
    print(json.dumps(out))


def first_gbuffers(args, peers_present):
    """Each tracer's first G-buffer, fresh processes alternated: the median of
    every field over --first-runs runs, by tracer."""
    who = ["rayfold"] + [k for k, cls in PEER_CLASSES.items() if cls.name in peers_present]
    runs = {w: [] for w in who}
    for _ in range(args.first_runs):
        for w in who:
            cmd = [sys.executable, os.path.abspath(__file__), args.scene, "--cameras", args.cameras, "--size", args.size,
                   "--threads", str(args.threads), "--first-gbuffer-child", w]
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode != 0:
                sys.exit(f"bench_python.py: the first G-buffer of {w} failed in a fresh process:\n{done.stderr}")
            runs[w].append(json.loads(done.stdout.strip().splitlines()[-1]))
    return {w: {k: statistics.median(r[k] for r in rs) for k in rs[0]} for w, rs in runs.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--cameras", required=True)
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--first-runs", type=int, default=3)
    ap.add_argument("--first-gbuffer-child", choices=["rayfold"] + list(PEER_CLASSES), help=argparse.SUPPRESS)
    ap.add_argument("--json")
    ap.add_argument("--md")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    if args.first_gbuffer_child:
        return first_gbuffer_child(args, args.first_gbuffer_child, width, height)

    scene = rayfold.Scene(args.scene)
    cams = cameras_from(args.cameras, width, height)
    renderer = rayfold.Renderer(scene, threads=args.threads)
    exact = rayfold.Renderer(scene, threads=args.threads, exact_depth=True)
    world = scene.world_triangles()
    tris = world.triangles

    peers, skipped = [], []
    for cls, pkg in ((Mitsuba, "mitsuba"), (Open3D, "open3d-cpu")):
        try:
            peers.append(cls(tris, args.threads))
        except ImportError as e:
            skipped.append(f"{cls.name}: cannot be imported ({e}); not timed (pip install {pkg})")

    ours_ms = {f: [] for f in FOLDS}
    depth_ms = {f: [] for f in FOLDS}
    exact_ms = {f: [] for f in FOLDS}
    peer_ms = {p.name: [] for p in peers}
    checks = {p.name: [] for p in peers}
    accuracies = {name: [] for name in ["rayfold", "rayfold exact_depth"] + [p.name for p in peers]}
    for cam in cams:
        reference = scene.render_reference(cam, threads=args.threads)
        depth = None
        for f in FOLDS:
            ms, g = timed(lambda: renderer.render(cam, fold=f), args.frames, args.warmup)
            ours_ms[f].append(ms)
            depth = g.depth.reshape(-1)
            ms, d = timed(lambda: renderer.render(cam, fold=f, channels="depth"), args.frames, args.warmup)
            depth_ms[f].append(ms)
            if not np.array_equal(d.depth.view(np.uint32), g.depth.view(np.uint32)):
                sys.exit(f"bench_python.py: channels='depth' changed the depth (fold {f}): a rayfold bug")
            ms, e = timed(lambda: exact.render(cam, fold=f), args.frames, args.warmup)
            exact_ms[f].append(ms)
            if not (np.array_equal(e.instance_id, g.instance_id) and np.array_equal(e.primitive_id, g.primitive_id)):
                sys.exit(f"bench_python.py: exact_depth changed the triangles hit (fold {f}): a rayfold bug")
        ids = (g.instance_id.reshape(-1), g.primitive_id.reshape(-1))
        accuracies["rayfold"].append(accuracy(reference, depth, *ids))
        accuracies["rayfold exact_depth"].append(accuracy(reference, e.depth.reshape(-1), *ids))
        origin = np.asarray(cam.eye, dtype=np.float32)
        dirs = np.asarray(cam.ray_directions(), dtype=np.float32)
        lengths = np.linalg.norm(dirs.reshape(-1, 3).astype(np.float64), axis=1)
        for p in peers:
            rays = p.prepare(origin, dirs)
            t, rows = p.hits(rays)
            hit, err = agreement(depth, t)
            checks[p.name].append((hit, err))
            # t is along the float32 direction, whose length is 1 only to
            # float rounding: as a distance, as rayfold-peers takes Embree's.
            accuracies[p.name].append(accuracy(reference, t * lengths, *peer_ids(world, rows)))
            if hit >= MIN_HIT_AGREEMENT and err <= MAX_MEDIAN_DEPTH_ERROR:
                ms, _ = timed(lambda: p.cast(rays), args.frames, args.warmup)
                peer_ms[p.name].append(ms)

    first = first_gbuffers(args, [p.name for p in peers]) if args.first_runs > 0 else {}

    best_fold = min(FOLDS, key=lambda f: statistics.median(ours_ms[f]))
    ours = statistics.median(ours_ms[best_fold])
    ours_depth = min(statistics.median(depth_ms[f]) for f in FOLDS)
    mpix = width * height / 1e3
    # Every fold gives rayfold's bits: one accuracy for all of its rows.
    ours_accuracy = over_views(accuracies["rayfold"])
    rows = [{"variant": f"rayfold Renderer.render, fold {f}", "ms": statistics.median(ours_ms[f]),
             "mpixels_per_s": mpix / statistics.median(ours_ms[f]), **ours_accuracy} for f in FOLDS]
    rows += [{"variant": f"rayfold Renderer.render, channels='depth', fold {f}", "ms": statistics.median(depth_ms[f]),
              "mpixels_per_s": mpix / statistics.median(depth_ms[f]), **ours_accuracy} for f in FOLDS]
    exact_accuracy = over_views(accuracies["rayfold exact_depth"])
    rows += [{"variant": f"rayfold Renderer.render, exact_depth, fold {f}", "ms": statistics.median(exact_ms[f]),
              "mpixels_per_s": mpix / statistics.median(exact_ms[f]), **exact_accuracy} for f in FOLDS]
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
                     "median_depth_difference": worst_err, **over_views(accuracies[p.name])})

    name = os.path.splitext(os.path.basename(args.scene))[0]
    machine = machine_info(renderer)
    lines = [f"Scene `{name}`: {len(tris)} triangles; {width}x{height}, {len(cams)} views from {args.cameras}, "
             f"median of {args.frames} frames after {args.warmup}, {args.threads} threads, wall clock from Python.",
             f"Machine: {machine['cpu']} ({machine['isa']}); rayfold device: {machine['opencl_device']}, tile kernel "
             f"{machine['tile_lanes']} lanes" + "".join(f"; {k} {v}" for k, v in machine["peers"].items()) + ".",
             "", "| variant | ms/frame | Mpixels/s | rayfold's fastest fold against it: G-buffer | depth only |",
             "|---|---|---|---|---|"]
    for r in rows:
        ratio = f"**{r['ratio']:.2f}x**" if "ratio" in r else ""
        ratio_depth = f"**{r['ratio_depth_only']:.2f}x**" if "ratio_depth_only" in r else ""
        lines.append(f"| {r['variant']} | {r['ms']:.1f} | {r['mpixels_per_s']:.1f} | {ratio} | {ratio_depth} |")
    lines += ["", "Against the double-precision reference (Scene.render_reference): share of pixels on another "
              "triangle, share hit on one side only, relative depth error where both hit the same triangle "
              "(median of the views' medians / largest p99 / largest maximum).", "",
              "| tracer | other triangle | hit/miss | depth error |", "|---|---|---|---|"]
    exact_row = next(r for r in rows if "exact_depth" in r["variant"])
    tracers = [("rayfold (every fold)", rows[0]), ("rayfold exact_depth (every fold)", exact_row)]
    tracers += [(r["variant"], r) for r in rows if "ratio" in r]
    for who, r in tracers:
        lines.append(f"| {who} | {100 * r['disagreeing_share']:.4f}% | {100 * r['hit_miss_share']:.4f}% | "
                     f"{r['depth_error_median']:.1e} / {r['depth_error_p99']:.1e} / {r['depth_error_max']:.1e} |")
    if first:
        r = first["rayfold"]
        lines += ["", f"First G-buffer of view 0 in a fresh process (median of {args.first_runs}, imports not counted): "
                  f"rayfold {r['total']:.0f} ms (load {r['load']:.0f}, Renderer {r['renderer']:.0f}, first render "
                  f"{r['frame']:.0f})" + "".join(f"; {PEER_CLASSES[w].name.split(' ')[0]} "
                                                  f"{first[w]['total']:.0f} ms (scene build and first call, the "
                                                  "triangles given)" for w in first if w != "rayfold") + "."]
    for note in skipped + failed:
        lines.append(f"\n{note}")
    md = "\n".join(lines) + "\n"
    print(md)
    if args.md:
        with open(args.md, "w") as f:
            f.write(md)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"scene": name, "machine": machine, "width": width, "height": height, "views": len(cams),
                       "frames": args.frames,
                       "threads": args.threads, "fastest_fold": best_fold, "rows": rows, "first_gbuffer_ms": first,
                       "skipped": skipped, "failed": failed}, f, indent=1)
    return 3 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
