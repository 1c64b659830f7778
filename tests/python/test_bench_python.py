"""tools/bench/bench_python.py's inputs are real: the world-space triangles it gives
the peers are the ones rayfold renders, and its agreement check sees a
disagreement."""
import importlib.util
import json

import numpy as np
import pytest

import rayfold
from conftest import ROOT

spec = importlib.util.spec_from_file_location("bench_python", ROOT / "tools" / "bench" / "bench_python.py")
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)


def first_hits(origin, dirs, tris):
    """Closest hit distance per ray over all triangles, Moeller-Trumbore in float64."""
    o = origin.astype(np.float64)
    v0, v1, v2 = (tris[:, k].astype(np.float64) for k in range(3))
    e1, e2 = v1 - v0, v2 - v0
    out = np.full(len(dirs), np.inf)
    for i, d in enumerate(dirs.astype(np.float64)):
        p = np.cross(d, e2)
        det = np.einsum("ij,ij->i", e1, p)
        ok = np.abs(det) > 1e-300
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
        s = o - v0
        u = np.einsum("ij,ij->i", s, p) * inv
        q = np.cross(s, e1)
        v = (q @ d) * inv
        t = np.einsum("ij,ij->i", e2, q) * inv
        hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        if hit.any():
            out[i] = t[hit].min()
    return out


def test_world_triangles_are_what_rayfold_renders(atrium_path):
    """Scene.world_triangles (what the bench hands the peers) against brute
    force on the rendered depths, and its row map against the G-buffer's ids:
    the row of a hit's (instance, primitive) is a triangle through the hit."""
    scene = rayfold.Scene(atrium_path)
    world = scene.world_triangles()
    tris = world.triangles
    assert tris.shape == (scene.triangle_count, 3, 3) and tris.dtype == np.float32
    assert world.first_row[0] == 0 and world.first_row[-1] == len(tris)
    for inst in range(scene.instance_count):
        rows = slice(world.first_row[inst], world.first_row[inst + 1])
        assert np.all(world.instance_id[rows] == inst)
        np.testing.assert_array_equal(world.primitive_id[rows], np.arange(rows.stop - rows.start))
    cam = scene.default_camera(48, 27)
    g = scene.render(cam, backend="cpu")
    dirs = np.asarray(cam.ray_directions(), dtype=np.float32).reshape(-1, 3)
    rng = np.random.default_rng(3)
    pick = rng.choice(len(dirs), 40, replace=False)
    want = g.depth.reshape(-1)[pick]
    got = first_hits(np.asarray(cam.eye), dirs[pick], tris)
    assert np.isfinite(want).sum() > 20
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
    both = np.isfinite(want)
    assert np.max(np.abs(got[both] - want[both]) / want[both]) < 1e-4
    # Each hit pixel's triangle, found through first_row, holds its hit point.
    hit = g.instance_id.reshape(-1) != rayfold.MISS
    rows = world.first_row[g.instance_id.reshape(-1)[hit]] + g.primitive_id.reshape(-1)[hit]
    t = tris[rows].astype(np.float64)
    points = np.asarray(cam.eye) + g.depth.reshape(-1)[hit, None] * dirs[hit].astype(np.float64)
    n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    off_plane = np.abs(np.einsum("ij,ij->i", points - t[:, 0], n)) / g.depth.reshape(-1)[hit]
    assert hit.sum() > 100 and np.max(off_plane) < 1e-4


def test_agreement_sees_a_disagreement():
    d = np.array([1.0, 2.0, np.inf, 4.0], dtype=np.float32)
    assert bench.agreement(d, d) == (1.0, 0.0)
    hit, err = bench.agreement(d, np.array([1.0, np.inf, np.inf, 4.4], dtype=np.float32))
    assert hit == 0.75 and err == pytest.approx(0.05)


def test_cameras_come_from_a_peers_report(tmp_path):
    path = tmp_path / "peers.json"
    path.write_text(json.dumps({"cameras": [{"eye": [0, 1, 5], "look_at": [0, 1, 0], "up": [0, 1, 0], "vfov": 50}]}))
    (cam,) = bench.cameras_from(str(path), 64, 36)
    assert (cam.width, cam.height) == (64, 36)
    (tmp_path / "none.json").write_text("{}")
    with pytest.raises(SystemExit, match="no 'cameras' list"):
        bench.cameras_from(str(tmp_path / "none.json"), 64, 36)


def test_intersect_on_incoherent_rays_agrees_with_a_float64_brute_force(atrium_path):
    """tools/bench/bench_rays.py's incoherent rays through scene.intersect against
    every triangle in float64: the same hits and misses but for near ties,
    t within a few float roundings."""
    import sys
    sys.path.insert(0, str(ROOT / "tools" / "bench"))
    rays_spec = importlib.util.spec_from_file_location("bench_rays", ROOT / "tools" / "bench" / "bench_rays.py")
    bench_rays = importlib.util.module_from_spec(rays_spec)
    rays_spec.loader.exec_module(bench_rays)
    scene = rayfold.Scene(atrium_path)
    o, d = bench_rays.incoherent_rays(scene, 300, seed=7)
    tris = scene.world_triangles().triangles
    expected = np.array([first_hits(o[i], d[i:i + 1], tris)[0] for i in range(len(o))])
    for backend in ("cpu", "opencl"):
        t = scene.intersect(o, d, backend=backend)["t"]
        hit, err = bench.agreement(expected, t)
        assert hit >= 0.99 and err < 1e-6, (backend, hit, err)
        both = np.isfinite(t) & np.isfinite(expected)
        assert both.sum() > 200
        assert np.quantile(np.abs(t[both] - expected[both]) / expected[both], 0.99) < 1e-4


def _bench_readback():
    import sys
    sys.path.insert(0, str(ROOT / "tools" / "bench"))
    spec = importlib.util.spec_from_file_location("bench_readback", ROOT / "tools" / "bench" / "bench_readback.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_readback_bench_checks_the_packed_planes_and_reports_both(atrium_path, monkeypatch):
    rb = _bench_readback()
    rows = rb.bench_scene(atrium_path, views=4, width=64, height=48, chunk=2, repeats=1)
    assert {(r["channels"], r["readback"]) for r in rows} == {
        (c or "all", m) for c in rb.CHANNEL_SETS for m in ("hits", "packed")}
    assert all(r["views_per_s"] > 0 and r["trace_ms_per_view"] > 0 for r in rows)
    # Its check sees a plane that differs, one that is missing, and a hit count.
    scene = rayfold.Scene(str(atrium_path))
    cam = scene.default_camera(32, 24)
    a, b = scene.render(cam), scene.render(cam)
    assert rb.same_planes(a, b) == ""
    b.depth[3, 4] += 1.0
    assert rb.same_planes(a, b) == "depth differs"
    c = scene.render(cam, channels="depth")
    assert rb.same_planes(a, c) == "normal present in one only"


def test_render_reference_is_a_float64_brute_force(atrium_path):
    """Scene.render_reference (what every tracer's accuracy is measured
    against) on random pixels against a float64 brute force over every
    triangle, as the file states it, along the camera's double rays: the
    same hits and misses and t to double rounding, far below a float
    render's error; its ids are the render's on nearly every pixel."""
    scene = rayfold.Scene(atrium_path)
    cam = scene.default_camera(64, 36)
    ref = scene.render_reference(cam, threads=2)
    assert ref["depth"].shape == (36, 64) and ref["depth"].dtype == np.float64
    assert ref["instance_id"].shape == (36, 64) and ref["instance_id"].dtype == np.uint32
    assert ref["primitive_id"].dtype == np.uint32
    dirs = np.asarray(cam.ray_directions()).reshape(-1, 3)
    pick = np.random.default_rng(5).choice(len(dirs), 40, replace=False)
    # The geometry as the file states it: object vertices through the
    # instance transforms in double (world_triangles' floats are rounded).
    exact = []
    for inst in range(scene.instance_count):
        mesh = scene.instance_mesh(inst)
        p = np.asarray(scene.mesh_positions(mesh), dtype=np.float64).reshape(-1, 3)
        m = np.asarray(scene.transform(inst), dtype=np.float64)
        exact.append((p @ m[:3, :3].T + m[:3, 3])[np.asarray(scene.mesh_triangles(mesh)).reshape(-1, 3)])
    want = first_hits(np.asarray(cam.eye), dirs[pick], np.concatenate(exact))
    got = ref["depth"].reshape(-1)[pick]
    np.testing.assert_array_equal(np.isfinite(got), np.isfinite(want))
    both = np.isfinite(want)
    assert both.sum() > 20
    assert np.max(np.abs(got[both] - want[both]) / want[both]) < 1e-9
    miss = ~np.isfinite(ref["depth"])
    assert np.all((ref["instance_id"] == rayfold.MISS) == miss)
    g = scene.render(cam)
    same = (g.instance_id == ref["instance_id"]) & (g.primitive_id == ref["primitive_id"])
    assert same.mean() > 0.99
    err = np.abs(g.depth[same & ~miss] - ref["depth"][same & ~miss]) / ref["depth"][same & ~miss]
    assert 0 < np.max(err) < 1e-4  # a float render is off by float rounding, never exactly the reference


def test_accuracy_is_measured_against_the_reference_as_rayfold_peers_does():
    ref = {"depth": np.array([1.0, 2.0, np.inf, 4.0, 5.0]),
           "instance_id": np.array([0, 0, rayfold.MISS, 1, 1], dtype=np.uint32),
           "primitive_id": np.array([3, 4, rayfold.MISS, 0, 1], dtype=np.uint32)}
    # Pixel 1 a tenth of a percent deep, pixel 3 on another triangle, pixel 4 a miss.
    depth = np.array([1.0, 2.002, np.inf, 4.0, np.inf], dtype=np.float32)
    inst = np.array([0, 0, rayfold.MISS, 1, rayfold.MISS], dtype=np.uint32)
    prim = np.array([3, 4, rayfold.MISS, 2, rayfold.MISS], dtype=np.uint32)
    a = bench.accuracy(ref, depth, inst, prim)
    assert a["disagreeing_share"] == pytest.approx(0.4) and a["hit_miss_share"] == pytest.approx(0.2)
    assert a["depth_error_max"] == pytest.approx(1e-3, rel=1e-4)
    assert a["depth_error_p99"] == a["depth_error_median"] == a["depth_error_max"]  # 2 errors: 0 and 1e-3
    # Rows of world_triangles map to ids; -1 is a miss.
    world = rayfold.Scene().world_triangles()._replace(instance_id=np.array([0, 1, 1], dtype=np.uint32),
                                                       primitive_id=np.array([7, 0, 1], dtype=np.uint32))
    i, p = bench.peer_ids(world, np.array([2, -1, 0]))
    assert list(i) == [1, rayfold.MISS, 0] and list(p) == [1, rayfold.MISS, 7]
    views = [a, dict(a, depth_error_max=0.5, depth_error_p99=0.25, disagreeing_share=0.0, depth_error_median=0.1)]
    over = bench.over_views(views)
    assert over["depth_error_max"] == 0.5 and over["depth_error_p99"] == 0.25
    assert over["disagreeing_share"] == pytest.approx(0.2)
    assert over["depth_error_median"] == 0.1  # of two, the upper, as rayfold-peers' core::median


def test_chart_draws_mitsuba_and_open3d_beside_rayfold_and_embree():
    """tools/bench/chart_peers.py's points: each C++ variant once, at its fastest
    fold, and from the Python report rayfold's fastest fold of each G-buffer
    kind (not the depth-only renders) and every peer with an accuracy."""
    spec = importlib.util.spec_from_file_location("chart_peers", ROOT / "tools" / "bench" / "chart_peers.py")
    chart = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(chart)
    acc = {"depth_error_p99": 1e-6, "depth_error_max": 1e-5, "disagreeing_share": 1e-3}
    peers = {"rows": [dict(acc, variant="OpenCL tile", fold="none", mpixels_per_s=10.0),
                      dict(acc, variant="OpenCL tile", fold="xy", mpixels_per_s=12.0),
                      dict(acc, variant="Embree flat rtcIntersect16", fold="-", mpixels_per_s=8.0)]}
    python = {"rows": [dict(acc, variant="rayfold Renderer.render, fold none", mpixels_per_s=5.0),
                       dict(acc, variant="rayfold Renderer.render, fold y", mpixels_per_s=6.0),
                       dict(acc, variant="rayfold Renderer.render, channels='depth', fold y", mpixels_per_s=9.0),
                       dict(acc, variant="rayfold Renderer.render, exact_depth, fold x", mpixels_per_s=4.5),
                       dict(acc, variant="rayfold Renderer.render, exact_depth, fold xy", mpixels_per_s=4.0),
                       dict(acc, variant="Mitsuba 3 ray_intersect (llvm_ad_rgb)", mpixels_per_s=4.0),
                       dict(acc, variant="Open3D RaycastingScene.cast_rays", mpixels_per_s=3.0)]}
    drawn = [(label, row["mpixels_per_s"], filled) for label, row, filled in chart.points(peers, python)]
    assert drawn == [("OpenCL tile, fold xy", 12.0, True), ("Embree flat rtcIntersect16", 8.0, True),
                     ("from Python: rayfold Renderer.render, fold y", 6.0, False),
                     ("from Python: rayfold Renderer.render, exact_depth, fold x", 4.5, False),
                     ("from Python: Mitsuba 3 ray_intersect (llvm_ad_rgb)", 4.0, False),
                     ("from Python: Open3D RaycastingScene.cast_rays", 3.0, False)]
    assert [label for label, _, _ in chart.points(peers, None)] == ["OpenCL tile, fold xy",
                                                                     "Embree flat rtcIntersect16"]
