#!/usr/bin/env python3
"""The dataset loop, cameras in and a G-buffer EXR out per view, against Mitsuba 3's
`aov` integrator and Blender's Cycles render passes on the same views (issue 49, part
6): rayfold renders depth, shading normal, position, texture coordinates and instance
ids and writes them as one EXR; Mitsuba renders the same AOVs (depth, sh_normal,
position, uv, shape_index) at one sample per pixel centre and writes its EXR; Blender
(`blender -b`, Debian's, running blender_passes.py) imports the glTF itself and renders
the same passes (Z, Normal, Position, UV, IndexOB) with Cycles at one sample, no
bounces, persistent data, into one multilayer EXR a view. Same machine, same run:
rayfold and Mitsuba take turns view by view, Blender's process renders every view
first; medians over the views (each view's time once warm). Without a `blender` on
PATH (apt-get install blender python3-numpy; or --blender PATH) its row is left out
and the run says so.

Mitsuba reads no glTF: trimesh (PyPI) loads the file, and each mesh goes to Mitsuba
in world space with the file's normals and texture coordinates where it has them
(read from trimesh's cache: it makes normals only when asked). Mitsuba's meshes carry
no alpha masks: on a scene with alphaMode MASK the hit-point check below fails.
Before any time is reported, each view's hit points are compared, rayfold's with
Mitsuba's and with Blender's Position pass: where both hit, they agree within 1e-4 of the
distance on at least 99% of the pixels, or the view is named and the run fails (a camera
or scene mismatch would make the timing meaningless).

usage: bench_dataset_loop.py SCENE --cameras PEERS.json [--size WxH] [--views K] [--exr-compression M]
                             [--blender PATH | --no-blender] [--json OUT]
"""
import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
import rayfold

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bench_python import cameras_from, machine_info  # noqa: E402

CHANNELS = "depth,shading_normal,position,texcoord,instance_id"
AOVS = "dd:depth,nn:sh_normal,pp:position,uv:uv,id:shape_index"


def mitsuba_scene(path, mi):
    """The file's meshes in world space as Mitsuba meshes (trimesh's scene graph)."""
    import trimesh
    loaded = trimesh.load(path, force="scene", process=False)
    shapes = {"type": "scene"}
    for k, node in enumerate(loaded.graph.nodes_geometry):
        transform, name = loaded.graph[node]
        g = loaded.geometry[name]
        if not hasattr(g, "faces") or len(g.faces) == 0:
            continue
        v = np.c_[np.asarray(g.vertices, np.float64), np.ones(len(g.vertices))] @ transform.T
        normals = "vertex_normals" in g._cache  # the file's own; trimesh makes them only when asked
        uv = getattr(g.visual, "uv", None)
        mesh = mi.Mesh(f"m{k}", len(g.vertices), len(g.faces), has_vertex_normals=normals,
                       has_vertex_texcoords=uv is not None)
        params = mi.traverse(mesh)
        params["vertex_positions"] = v[:, :3].astype(np.float32).ravel()
        params["faces"] = np.asarray(g.faces, np.uint32).ravel()
        if normals:
            n = np.asarray(g.vertex_normals, np.float64) @ np.linalg.inv(transform[:3, :3])
            params["vertex_normals"] = n.astype(np.float32).ravel()
        if uv is not None:
            params["vertex_texcoords"] = np.asarray(uv, np.float32).ravel()
        params.update()
        shapes[f"m{k}"] = mesh
    return mi.load_dict(shapes)


def mitsuba_sensor(mi, view, width, height):
    """A pinhole camera as rayfold-peers' view; one sample at each pixel's centre."""
    return mi.load_dict({
        "type": "perspective", "fov_axis": "y", "fov": view["vfov"],
        "to_world": mi.ScalarTransform4f().look_at(origin=view["eye"], target=view["look_at"], up=view["up"]),
        "sampler": {"type": "stratified", "sample_count": 1, "jitter": False},
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                 "pixel_format": "rgb", "component_format": "float32"},
    })


def blender_passes(blender, scene_path, views, width, height, out, reps):
    """Blender's run of blender_passes.py: its report (times per view) and the EXRs in `out`."""
    views_path = os.path.join(out, "views.json")
    with open(views_path, "w") as f:
        json.dump(views, f)
    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "blender_passes.py")
    cmd = [blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python", script, "--",
           os.path.abspath(scene_path), views_path, f"{width}x{height}", out, str(reps)]
    done = subprocess.run(cmd, capture_output=True, text=True)
    report = os.path.join(out, "blender.json")
    if done.returncode != 0 or not os.path.exists(report):
        tail = "\n".join((done.stdout + done.stderr).strip().splitlines()[-12:])
        sys.exit(f"bench_dataset_loop.py: {blender} failed on {scene_path} (exit {done.returncode}):\n{tail}")
    with open(report) as f:
        return json.load(f)


def blender_points(mi, path):
    """The Position pass of Blender's EXR, turned back into glTF's frame ((x, y, z) <- (x, z, -y)), and
    where it hit (IndexOB: blender_passes.py numbers the meshes from 1)."""
    passes = dict(mi.Bitmap(path).split())
    p = np.asarray(passes["ViewLayer.Position"], np.float64)
    hits = np.asarray(passes["ViewLayer.IndexOB"], np.float64).reshape(p.shape[:2]) > 0
    return np.stack([p[..., 0], p[..., 2], -p[..., 1]], -1), hits


def agreement(points, peer_hits, g):
    """The share of pixels both hit whose points agree within 1e-4 of rayfold's distance."""
    both = (g.instance_id != rayfold.MISS) & peer_hits
    close = np.linalg.norm(points[both] - g.position[both], axis=1) <= 1e-4 * g.depth[both]
    return float(close.mean()) if both.any() else 0.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--cameras", required=True, help="a rayfold-peers --json report with random views")
    ap.add_argument("--size", default="1280x720")
    ap.add_argument("--views", type=int, default=4)
    ap.add_argument("--exr-compression", default="zip", help="rayfold's EXR compression (zip, the default, or none)")
    ap.add_argument("--blender", default=shutil.which("blender"), help="Blender's binary (default: on PATH)")
    ap.add_argument("--no-blender", action="store_true", help="leave Blender's row out")
    ap.add_argument("--json", help="write the figures here too")
    a = ap.parse_args()
    blender = None if a.no_blender else a.blender
    if blender is None:
        print("bench_dataset_loop.py: " + ("--no-blender" if a.no_blender else "no blender on PATH (apt-get install "
              "blender python3-numpy, or --blender PATH)") + ": Blender's Cycles row left out", flush=True)
    width, height = map(int, a.size.split("x"))
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    with open(a.cameras) as f:
        views = json.load(f)["cameras"][:a.views]
    cameras = cameras_from(a.cameras, width, height)[:a.views]

    t0 = time.perf_counter()
    scene = rayfold.Scene(a.scene)
    scene.render(cameras[0], channels=CHANNELS)  # the attributes read, the kernels built
    rayfold_setup = time.perf_counter() - t0
    t0 = time.perf_counter()
    ms = mitsuba_scene(a.scene, mi)
    integrator = mi.load_dict({"type": "aov", "aovs": AOVS})
    mitsuba_setup = time.perf_counter() - t0

    out = tempfile.mkdtemp(prefix="bench_dataset_loop_")
    cycles = blender_passes(blender, a.scene, views, width, height, out, 3) if blender else None
    rows = []
    for i, (view, camera) in enumerate(zip(views, cameras)):
        sensor = mitsuba_sensor(mi, view, width, height)
        times = {k: [] for k in ("rayfold", "rayfold_write", "mitsuba", "mitsuba_write")}
        for rep in range(3):  # the first of each is a warm-up
            t = time.perf_counter()
            g = scene.render(camera, fold="xy", channels=CHANNELS)
            w = time.perf_counter()
            g.write_exr(os.path.join(out, f"rayfold_{i}.exr"), scene, compression=a.exr_compression)
            times["rayfold"].append(w - t)
            times["rayfold_write"].append(time.perf_counter() - w)
            t = time.perf_counter()
            # On the host, as rayfold's planes are: Dr.Jit evaluates lazily.
            img = np.asarray(mi.render(ms, sensor=sensor, integrator=integrator, spp=1))
            w = time.perf_counter()
            mi.Bitmap(img).write(os.path.join(out, f"mitsuba_{i}.exr"))
            times["mitsuba"].append(w - t)
            times["mitsuba_write"].append(time.perf_counter() - w)
        # Validated before reported: Mitsuba's channels are the AOVs alone (no inner integrator), in
        # AOVS's order: dd, nn (3), pp (3), uv (2), id.
        # (Its depth AOV is not always the ray's distance: the points are compared.)
        agree = {"mitsuba": agreement(img[..., 4:7], img[..., 0] > 0, g)}
        if cycles:
            b = cycles["views"][i]
            times["blender"], times["blender_write"] = [t / 1e3 for t in b["render_ms"]], [t / 1e3 for t in b["write_ms"]]
            agree["blender"] = agreement(*blender_points(mi, os.path.join(out, f"blender_{i}.exr")), g)
        for peer, share in agree.items():
            if share < 0.99:
                sys.exit(f"bench_dataset_loop.py: view {i}: rayfold's and {peer}'s hit points agree on "
                         f"{100 * share:.1f}% of the pixels both hit: not the same view or scene, no times reported")
        rows.append({"view": i, "point_agreement": agree,
                     **{f"{k}_ms": 1e3 * statistics.median(v[1:]) for k, v in times.items()}})
        line = (f"view {i}: rayfold {rows[-1]['rayfold_ms']:.1f} + {rows[-1]['rayfold_write_ms']:.1f} ms, "
                f"Mitsuba aov {rows[-1]['mitsuba_ms']:.1f} + {rows[-1]['mitsuba_write_ms']:.1f} ms")
        if cycles:
            line += f", Blender Cycles {rows[-1]['blender_ms']:.1f} + {rows[-1]['blender_write_ms']:.1f} ms"
        print(line + " (render + write); hit points agree on " +
              ", ".join(f"{100 * v:.2f}% ({k})" for k, v in agree.items()) + " of the pixels both hit", flush=True)
    med = {k: statistics.median(row[f"{k}_ms"] for row in rows) for k in times}
    loop_r, loop_m = med["rayfold"] + med["rayfold_write"], med["mitsuba"] + med["mitsuba_write"]
    info = machine_info()
    print(f"{os.path.basename(a.scene)} {width}x{height}, {len(rows)} random views, {info}:\n"
          f"  render, median per view: rayfold {med['rayfold']:.1f} ms, Mitsuba aov {med['mitsuba']:.1f} ms: "
          f"{med['mitsuba'] / med['rayfold']:.2f}x\n"
          f"  render + write EXR (rayfold {a.exr_compression}, Mitsuba its default): rayfold {loop_r:.1f} ms, "
          f"Mitsuba {loop_m:.1f} ms: {loop_m / loop_r:.2f}x\n"
          f"  set-up (load, first render): rayfold {rayfold_setup:.2f} s, Mitsuba (trimesh + scene) "
          f"{mitsuba_setup:.2f} s")
    if cycles:
        loop_b = med["blender"] + med["blender_write"]
        print(f"  Blender {cycles['blender']} Cycles passes (1 sample, no bounces, persistent data): render "
              f"{med['blender']:.1f} ms ({med['blender'] / med['rayfold']:.2f}x rayfold's), render + write EXR "
              f"(ZIP) {loop_b:.1f} ms ({loop_b / loop_r:.2f}x); its glTF import {cycles['import_s']:.2f} s")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"scene": a.scene, "size": [width, height], "channels": CHANNELS, "aovs": AOVS,
                       "exr_compression": a.exr_compression, "machine": info, "views": rows,
                       "medians_ms": med, "rayfold_setup_s": rayfold_setup, "mitsuba_setup_s": mitsuba_setup,
                       "blender": cycles and {"version": cycles["blender"], "import_s": cycles["import_s"]}},
                      f, indent=1)


if __name__ == "__main__":
    main()
