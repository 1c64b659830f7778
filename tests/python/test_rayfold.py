"""The Python module against the CLI, against the scene's own triangles, and
against itself written another way; and its errors."""
import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import rayfold

PLANES = ["depth", "normal", "uv", "instance_id", "primitive_id"]


def bits(a):
    """An array's bits, so that NaN, -0 and inf compare exactly."""
    return a.view(np.uint32) if a.dtype == np.float32 else a


def assert_same_bits(a, b):
    for name in PLANES:
        x, y = bits(getattr(a, name)), bits(getattr(b, name))
        differ = np.argwhere(x != y)
        assert differ.size == 0, f"{name}: {len(differ)} values differ, first at {differ[0].tolist()}"


@pytest.fixture(scope="module")
def atrium(atrium_path):
    return rayfold.Scene(atrium_path)


def test_arrays_have_the_documented_shapes_and_types(atrium):
    camera = atrium.default_camera(64, 36)
    g = atrium.render(camera, fold="xy")
    assert g.depth.shape == (36, 64) and g.depth.dtype == np.float32
    assert g.normal.shape == (36, 64, 3) and g.normal.dtype == np.float32
    assert g.uv.shape == (36, 64, 2) and g.uv.dtype == np.float32
    assert g.instance_id.shape == (36, 64) and g.instance_id.dtype == np.uint32
    assert g.primitive_id.shape == (36, 64) and g.primitive_id.dtype == np.uint32
    # The planes wrap the C++ buffers (no copy): numpy does not own them.
    for name in PLANES:
        a = getattr(g, name)
        assert a.flags.c_contiguous and not a.flags.owndata, name
    miss = g.instance_id == rayfold.MISS
    assert 0 < miss.sum() < miss.size
    assert np.all(np.isinf(g.depth[miss])) and np.all(np.isfinite(g.depth[~miss]))
    assert np.all(g.primitive_id[miss] == rayfold.MISS)
    assert g.hits == int((~miss).sum())
    assert len(atrium.instance_names) == atrium.instance_count
    assert int(g.instance_id[~miss].max()) < atrium.instance_count


def test_render_views_equals_each_view_alone(atrium):
    """Views traced together (alignment) give each view's bits alone."""
    base = atrium.default_camera(40, 24)
    eye = np.array(base.eye)
    left, right = rayfold.Camera.stereo_pair(eye, (0, 2, 0), (0, 1, 0), 50.0, 40, 24, baseline=0.3)
    path = [rayfold.Camera.look_at(eye + (0.4 * k, 0, -0.3 * k), (0, 2, 0), (0, 1, 0), 50.0, 40, 24) for k in range(4)]
    views = [left, right] + path + [atrium.default_camera(40, 24)]
    for fold in ["none", "xy"]:
        for align in [0, 1, 3]:
            gs = atrium.render_views(views, fold=fold, align=align)
            assert len(gs) == len(views)
            for v, g in zip(views, gs):
                assert_same_bits(atrium.render(v, fold=fold), g)
        assert atrium.render_views(views, fold=fold)[0].views_in_trace == 6
    assert np.allclose(np.array(right.eye) - np.array(left.eye),
                       0.3 * right.camera_to_world[:3, 0])
    with pytest.raises(rayfold.InputError):
        atrium.render_views(views, align=-1)


def test_iter_views_streams_any_iterable_with_each_views_bits(atrium):
    """70 views from a generator cross two chunk boundaries (32 views each);
    two intrinsics interleave; each view's bits are its own render's."""
    base = atrium.default_camera(40, 24)
    eye = np.array(base.eye)
    views = [rayfold.Camera.look_at(eye + (0.05 * k, 0, 0), (0, 2, 0), (0, 1, 0), 50.0 if k % 3 else 65.0, 40, 24)
             for k in range(70)]
    consumed = []

    def cameras():
        for k, v in enumerate(views):
            consumed.append(k)
            yield v

    stream = atrium.iter_views(cameras(), fold="xy")
    first = next(stream)
    assert len(consumed) == 32, "the generator is read one chunk at a time"
    gs = [first] + list(stream)
    assert len(gs) == len(views)
    for k, (v, g) in enumerate(zip(views, gs)):
        assert_same_bits(atrium.render(v, fold="xy"), g)
        assert 1 <= g.views_in_trace <= 8, k
    assert max(g.views_in_trace for g in gs) == 8
    assert list(atrium.iter_views([])) == []
    with pytest.raises(TypeError, match="camera 33 is a str"):
        list(atrium.iter_views(views[:33] + ["not a camera"]))


def test_iter_views_memory_stays_flat_over_10000_views(atrium_path):
    """Holding 10,000 G-buffers of 64x48 would take 98 MB; the stream's peak
    stays within 16 MB of its resident set after the first 100 views."""
    worker = Path(__file__).with_name("iter_views_worker.py")
    out = subprocess.run([sys.executable, str(worker), atrium_path, "10000"], capture_output=True, text=True,
                         timeout=600, check=True)
    r = json.loads(out.stdout)
    assert r["views"] == 10000
    assert r["hits"] > 0
    assert r["peak"] - r["after_100"] < 16 << 20, r


def test_from_matrices_equals_from_matrix_per_camera_and_names_the_bad_one(atrium):
    base = atrium.default_camera(64, 40)
    fx, fy, cx, cy = base.intrinsics
    K = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]])
    c2w = np.stack([base.camera_to_world_in("opencv")] * 3)
    c2w[1, :3, 3] += (0.5, 0.0, -0.25)
    for k in [K, np.stack([K] * 3)]:
        cams = rayfold.Camera.from_matrices(c2w, k, 64, 40, convention="opencv")
        assert len(cams) == 3
        for m, c in zip(c2w, cams):
            one = rayfold.Camera.from_matrix(m, fx, fy, cx, cy, 64, 40, convention="opencv")
            np.testing.assert_array_equal(c.camera_to_world, one.camera_to_world)
            assert c.intrinsics == one.intrinsics
    assert_same_bits(atrium.render(cams[0]), atrium.render(base))
    bad = c2w.copy()
    bad[2, :3, :3] *= 2.0  # a scale, not a rigid pose
    with pytest.raises(rayfold.InputError, match="camera 2"):
        rayfold.Camera.from_matrices(bad, K, 64, 40, convention="opencv")
    skew = np.stack([K] * 3)
    skew[1, 0, 1] = 0.5
    with pytest.raises(rayfold.InputError, match=r"K\[1\] is not a pinhole"):
        rayfold.Camera.from_matrices(c2w, skew, 64, 40, convention="opencv")
    with pytest.raises(rayfold.InputError, match=r"\(B, 4, 4\)"):
        rayfold.Camera.from_matrices(c2w[0], K, 64, 40, convention="opencv")
    with pytest.raises(rayfold.InputError, match="K must be"):
        rayfold.Camera.from_matrices(c2w, np.stack([K] * 2), 64, 40, convention="opencv")


def test_dataset_cameras_see_what_their_files_say(tmp_path):
    """A camera at (1, 2, 3) looking along +x (right +z, up +y), fx = fy = 100,
    cx = 32, cy = 24 at 64x48 sees (11, 2.35, 3.85) at the centre of pixel
    (40, 20), written as NeRF and as COLMAP."""
    pose = [[0, 0, -1, 1], [0, 1, 0, 2], [1, 0, 0, 3], [0, 0, 0, 1]]
    nerf = tmp_path / "transforms.json"
    nerf.write_text(json.dumps({"fl_x": 100, "cx": 32, "cy": 24, "aabb_scale": 16,
                                "frames": [{"file_path": "images/a.png", "transform_matrix": pose}]}))
    with pytest.warns(UserWarning, match="ignored aabb_scale"):
        cams, names = rayfold.Camera.from_nerf(nerf, width=64, height=48)
    h = float(np.sqrt(0.5))
    (tmp_path / "cameras.txt").write_text("1 PINHOLE 64 48 100 100 32 24\n")
    (tmp_path / "images.txt").write_text(f"3 0 {h!r} 0 {h!r} -3 2 -1 1 a.png\n\n")
    colmap_cams, colmap_names = rayfold.Camera.from_colmap(tmp_path)
    assert names == ["images/a.png"] and colmap_names == ["a.png"]
    point = np.array([11.0, 2.35, 3.85])
    for c in cams + colmap_cams:
        assert (c.width, c.height) == (64, 48)
        to_point = (point - np.array(c.eye)) / np.linalg.norm(point - np.array(c.eye))
        np.testing.assert_allclose(c.ray_directions()[20, 40], to_point, rtol=0, atol=1e-6)
    with pytest.raises(rayfold.InputError, match="has no \"w\" and \"h\""):
        rayfold.Camera.from_nerf(nerf)
    (tmp_path / "cameras.txt").write_text("1 OPENCV 64 48 100 100 32 24 0.1 0 0 0\n")
    with pytest.raises(rayfold.InputError, match="OPENCV, a model with lens distortion"):
        rayfold.Camera.from_colmap(tmp_path)


def test_channels_fill_only_the_planes_asked_for(atrium):
    camera = atrium.default_camera(48, 30)
    full = atrium.render(camera, fold="xy")
    for channels in ["depth,instance_id", ["depth", "instance_id"], ("instance_id", "depth")]:
        g = atrium.render(camera, fold="xy", channels=channels)
        assert g.normal is None and g.uv is None and g.primitive_id is None
        np.testing.assert_array_equal(bits(g.depth), bits(full.depth))
        np.testing.assert_array_equal(g.instance_id, full.instance_id)
    (g,) = atrium.render_views([camera], channels="primitive_id")
    np.testing.assert_array_equal(g.primitive_id, full.primitive_id)
    assert g.depth is None
    (g,) = list(atrium.iter_views([camera], channels=["uv"]))
    np.testing.assert_array_equal(bits(g.uv), bits(full.uv))
    r = rayfold.Renderer(atrium)
    assert r.render(camera, channels="normal").depth is None
    # The tile kernel's width is named for benchmark reports; the CPU backend has none.
    assert r.tile_lanes in (8, 16) and rayfold.Renderer(atrium, backend="cpu").tile_lanes == 0
    g = atrium.render(camera, channels="Z,InstanceID")  # the EXR names work too
    assert g.normal is None and g.depth is not None and g.instance_id is not None
    with pytest.raises(rayfold.InputError, match="unknown channel 'colour'"):
        atrium.render(camera, channels="colour")
    with pytest.raises(rayfold.InputError, match="at least one"):
        atrium.render(camera, channels=[])


def page_faults():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def test_planes_numpy_let_go_are_rendered_into_again_with_fresh_bits(atrium):
    """A render reuses the memory of planes whose arrays were freed,
    overwriting them whole: a view that misses where the previous one hit, a
    smaller view, fewer channels and render_views all give the bits of a
    render into fresh memory. Reused, the planes cost no page faults, where
    fresh ones fault in every page (2405 at 640x480, all channels)."""
    inside = atrium.default_camera(640, 480)
    sky = rayfold.Camera.look_at((0, 200, 0), (0, 400, 0), (0, 0, 1), 60, 640, 480)  # looks away: misses
    small = atrium.default_camera(320, 240)
    r = rayfold.Renderer(atrium)
    want = {"inside": r.render(inside), "sky": r.render(sky), "small": r.render(small)}
    assert want["inside"].hits > 100000 and want["sky"].hits < want["inside"].hits // 2
    pages = 640 * 480 * 32 // 4096
    held = [r.render(inside)]
    before = page_faults()
    held.append(r.render(inside))  # nothing freed: fresh planes
    assert page_faults() - before > pages // 2, "the measure does not see fresh planes"
    g = r.render(inside)
    del g
    before = page_faults()
    g = r.render(sky)  # into the inside view's memory, which hit where it misses
    assert page_faults() - before < pages // 10, f"{page_faults() - before} page faults: the freed planes were not reused"
    assert_same_bits(g, want["sky"])
    del g
    assert_same_bits(r.render(small), want["small"])
    d = r.render(inside, channels="depth,instance_id")
    np.testing.assert_array_equal(bits(d.depth), bits(want["inside"].depth))
    np.testing.assert_array_equal(d.instance_id, want["inside"].instance_id)
    del d
    atrium.render_views([inside], align=1)  # the scene's own renderer's first frame makes its buffers
    g = r.render(sky)
    del g
    before = page_faults()
    views = atrium.render_views([inside], align=1)  # render_views takes freed planes too
    assert page_faults() - before < pages // 10, f"render_views: {page_faults() - before} page faults"
    assert_same_bits(views[0], want["inside"])
    # A view of the planes keeps them alive: they are not reused under it.
    g = r.render(inside)
    part = g.depth[10:20]
    copy = part.copy()
    del g
    r.render(sky)
    np.testing.assert_array_equal(bits(part), bits(copy))


def test_intersect_writes_over_the_arrays_numpy_let_go(atrium):
    """scene.intersect takes freed arrays' memory as render does (no page
    faults for them), with the answers of fresh memory: rays that miss after
    rays that hit."""
    cam = atrium.default_camera(640, 480)
    d = np.ascontiguousarray(cam.ray_directions(), dtype=np.float32)
    o = np.ascontiguousarray(np.broadcast_to(cam.ray_origins(), d.shape), dtype=np.float32)
    away = np.ascontiguousarray(np.broadcast_to(np.float32([0, 200, 0]), d.shape))
    up = np.ascontiguousarray(np.broadcast_to(np.float32([0, 1, 0]), d.shape))
    want = {k: v.copy() for k, v in atrium.intersect(away, up).items()}
    assert np.all(np.isinf(want["t"]))
    h = atrium.intersect(o, d)
    assert np.isfinite(h["t"]).sum() > 100000
    del h
    before = page_faults()
    h = atrium.intersect(away, up)
    assert page_faults() - before < 640 * 480 * 32 // 4096 // 10, f"{page_faults() - before} page faults"
    for k in want:
        np.testing.assert_array_equal(bits(h[k]), bits(want[k]), err_msg=k)


def test_exact_depth_changes_only_the_depth_and_is_the_same_everywhere(atrium):
    """exact_depth=True: each depth from the pixel's exact ray in double-float;
    the other planes are the float render's bits, the depth within float
    rounding of it, and every backend, kernel, fold and call gives the same
    bits."""
    camera = atrium.default_camera(48, 30)
    plain = atrium.render(camera)
    exact = atrium.render(camera, exact_depth=True)
    hit = np.isfinite(plain.depth)
    assert hit.sum() > 200
    np.testing.assert_allclose(exact.depth[hit], plain.depth[hit], rtol=1e-5)
    assert np.all(np.isinf(exact.depth[~hit]))
    assert np.any(bits(exact.depth) != bits(plain.depth)), "no pixel's depth changed"
    assert exact.exact_depth and not plain.exact_depth
    for plane in ("normal", "uv", "instance_id", "primitive_id"):
        np.testing.assert_array_equal(bits(getattr(exact, plane)), bits(getattr(plain, plane)))
    for g in [atrium.render(camera, fold="xy", exact_depth=True),
              atrium.render(camera, backend="cpu", exact_depth=True),
              atrium.render(camera, kernel="single", exact_depth=True),
              atrium.render_views([camera], exact_depth=True)[0],
              next(atrium.iter_views([camera], exact_depth=True)),
              rayfold.Renderer(atrium, exact_depth=True).render(camera)]:
        np.testing.assert_array_equal(bits(g.depth), bits(exact.depth))
    planar = atrium.render(camera, depth="planar", exact_depth=True)
    axis = -camera.camera_to_world[:3, 2]
    cosine = camera.ray_directions() @ axis
    np.testing.assert_allclose(planar.depth[hit], exact.depth[hit] * cosine[hit], rtol=1e-6)


def test_planar_depth_is_the_distance_along_the_camera_axis(atrium):
    """depth='planar': the distance times the cosine of each pixel's ray to the
    camera's axis, the same bits on every backend and kernel and through every
    call, the other planes unchanged."""
    camera = atrium.default_camera(48, 30)
    dist = atrium.render(camera, fold="xy")
    planar = atrium.render(camera, fold="xy", depth="planar")
    axis = -camera.camera_to_world[:3, 2]
    cosine = camera.ray_directions() @ axis
    hit = np.isfinite(dist.depth)
    assert hit.sum() > 200
    np.testing.assert_allclose(planar.depth[hit], dist.depth[hit] * cosine[hit], rtol=1e-6)
    assert np.all(np.isinf(planar.depth[~hit]))
    np.testing.assert_array_equal(planar.instance_id, dist.instance_id)
    np.testing.assert_array_equal(bits(planar.normal), bits(dist.normal))
    for g in [atrium.render(camera, fold="none", depth="planar", backend="cpu"),
              atrium.render(camera, depth="planar", kernel="single"),
              atrium.render_views([camera], depth="planar")[0],
              next(atrium.iter_views([camera], depth="planar")),
              rayfold.Renderer(atrium, depth="planar").render(camera)]:
        np.testing.assert_array_equal(bits(g.depth), bits(planar.depth))
    with pytest.raises(rayfold.InputError, match="depth must be 'distance'"):
        atrium.render(camera, depth="z")


def test_every_fold_backend_and_kernel_gives_the_same_bits(atrium):
    camera = atrium.default_camera(48, 30)
    ref = atrium.render(camera, backend="cpu")
    for backend, kernel in [("cpu", "auto"), ("opencl", "tile"), ("opencl", "single")]:
        for fold in ["none", "y", "x", "xy"]:
            g = atrium.render(camera, fold=fold, backend=backend, kernel=kernel)
            assert g.fold == fold
            assert_same_bits(ref, g)


def test_fold_auto_is_the_cost_models_choice_with_the_same_bits_and_says_how_the_time_went(atrium):
    cameras = [atrium.default_camera(64, 40), rayfold.Camera.look_at((0, 8, 30), (0, 6, 0), (0, 1, 0), 50, 64, 40)]
    ref = [atrium.render(c, backend="cpu") for c in cameras]
    r = rayfold.Renderer(atrium)
    choice = r.choose_fastest(cameras)
    assert choice["fold"] in ("none", "y", "x", "xy") and choice["kernel"] in ("tile", "single"), choice
    assert choice["align"] in (1, 32), choice
    totals = [p["total_ms"] for p in choice["predictions"]]
    assert totals == sorted(totals) and choice["predictions"][0]["fold"] == choice["fold"], choice
    assert r.choose_fastest(cameras[:1], folds=["xy"])["fold"] == "xy"
    for c, want in zip(cameras, ref):
        g = atrium.render(c, fold="auto")
        assert g.fold in ("none", "y", "x", "xy")
        assert_same_bits(want, g)
        assert g.kernel in ("tile", "single") and g.kernel_reason, (g.kernel, g.kernel_reason)
        assert g.stages["trace_ms"] == g.trace_ms > 0, (g.stages, g.trace_ms)
        assert set(g.stages) == {"cull_ms", "tlas_ms", "upload_ms", "ray_list_ms", "trace_ms", "readback_ms"}
        top = g.top_level
        assert top["scene_instances"] == 240 and 0 < top["traced_instances"] and top["out_of_range"] == 0, top
        assert top["sah_cost"] > 0, top
    for g, want in zip(atrium.render_views(cameras, fold="auto", align="auto"), ref):
        assert_same_bits(want, g)
    with pytest.raises(rayfold.InputError, match="align must be a count of views, 'all' or 'auto'"):
        atrium.render_views(cameras, align="most")
    with pytest.raises(rayfold.InputError, match="'auto'"):
        atrium.render(cameras[0], fold="yx!")


def test_python_equals_the_cli_exr_bit_for_bit(atrium_path, cli, tmp_path):
    openexr = pytest.importorskip("OpenEXR")
    out = tmp_path / "cli.exr"
    subprocess.run([cli, "render", atrium_path, "--size", "80x45", "--fold", "xy", "-o", str(out), "-q"], check=True)
    scene = rayfold.Scene(atrium_path)
    g = scene.render(scene.default_camera(80, 45), fold="xy")
    exr = openexr.File(str(out))
    ch = {name: c.pixels for name, c in exr.channels().items()}
    np.testing.assert_array_equal(bits(ch["Z"]), bits(g.depth))
    for k, name in enumerate(["N.X", "N.Y", "N.Z"]):
        np.testing.assert_array_equal(bits(ch[name]), bits(np.ascontiguousarray(g.normal[..., k])))
    np.testing.assert_array_equal(bits(ch["U"]), bits(np.ascontiguousarray(g.uv[..., 0])))
    np.testing.assert_array_equal(bits(ch["V"]), bits(np.ascontiguousarray(g.uv[..., 1])))
    np.testing.assert_array_equal(ch["InstanceID"], g.instance_id)
    np.testing.assert_array_equal(ch["PrimitiveID"], g.primitive_id)
    # The header's camera is the one Python used, and its names are the scene's.
    h = exr.header()
    cam = g.camera
    np.testing.assert_allclose(h["rayfold:cameraToWorld"].T, cam.camera_to_world, rtol=0, atol=1e-12)
    fx, fy, cx, cy = cam.intrinsics
    assert [np.ravel(h["rayfold:" + k])[0] for k in ["fx", "fy", "cx", "cy"]] == [fx, fy, cx, cy]
    assert list(h["rayfold:instanceNames"]) == scene.instance_names
    # worldToNDC (row vectors) takes each hit to its own pixel centre.
    hit = np.argwhere(g.instance_id != rayfold.MISS)[::97]
    dirs = cam.ray_directions()
    for y, x in hit:
        p = np.asarray(cam.eye) + g.depth[y, x] * dirs[y, x]
        ndc = np.append(p, 1.0) @ h["worldToNDC"].astype(np.float64)
        assert abs(ndc[0] / ndc[3] * 80 - (x + 0.5)) < 1e-2 and abs(ndc[1] / ndc[3] * 45 - (y + 0.5)) < 1e-2


def test_exr_compressions_read_back_the_same_bits(atrium_path, cli, tmp_path):
    """GBuffer.write_exr(compression=) and the CLI's --exr-compression write
    every lossless method with the same planes; none is the largest; a lossy
    method is refused by name."""
    scene = rayfold.Scene(atrium_path)
    g = scene.render(scene.default_camera(80, 45), fold="xy")
    sizes = {}
    for c in ("zip", "zips", "piz", "rle", "none"):
        path = tmp_path / f"{c}.exr"
        g.write_exr(path, scene, compression=c)
        back = rayfold.read_exr(path)
        for k in ("depth", "normal", "uv", "instance_id", "primitive_id"):
            np.testing.assert_array_equal(bits(back[k]), bits(getattr(g, k)), err_msg=f"{c} {k}")
        sizes[c] = os.path.getsize(path)
    assert sizes["none"] > 80 * 45 * 32 and sizes["zip"] < sizes["none"], sizes
    subprocess.run([cli, "render", atrium_path, "--size", "80x45", "--fold", "xy", "-o", str(tmp_path / "cli.exr"),
                    "--exr-compression", "none", "-q"], check=True)
    assert os.path.getsize(tmp_path / "cli.exr") > 80 * 45 * 32
    np.testing.assert_array_equal(bits(rayfold.read_exr(tmp_path / "cli.exr")["depth"]), bits(g.depth))
    with pytest.raises(rayfold.InputError, match="lossy"):
        g.write_exr(tmp_path / "b44.exr", scene, compression="b44")
    assert not (tmp_path / "b44.exr").exists()


def reprojection_error(scene, camera, g, min_hits, step):
    """The largest distance, relative to the depth, between each sampled hit
    put back on its ray (origin + depth * direction) and the same hit put on
    its triangle by its barycentrics; checks each normal is the triangle's."""
    dirs, origins = camera.ray_directions(), camera.ray_origins()
    ys, xs = np.nonzero(g.instance_id != rayfold.MISS)
    assert len(ys) > min_hits
    worst = 0.0
    for y, x in zip(ys[::step], xs[::step]):
        i, t = int(g.instance_id[y, x]), int(g.primitive_id[y, x])
        mesh = scene.instance_mesh(i)
        verts = scene.mesh_positions(mesh)[scene.mesh_triangles(mesh)[t]].astype(np.float64)
        world = (scene.transform(i) @ np.c_[verts, np.ones(3)].T).T[:, :3]
        u, v = g.uv[y, x]
        on_triangle = (1 - u - v) * world[0] + u * world[1] + v * world[2]
        from_depth = origins[y, x] + g.depth[y, x] * dirs[y, x]
        worst = max(worst, np.linalg.norm(on_triangle - from_depth) / g.depth[y, x])
        n = np.cross(world[1] - world[0], world[2] - world[0])
        assert abs(abs(np.dot(n / np.linalg.norm(n), g.normal[y, x])) - 1) < 1e-4
    return worst


def test_depth_reprojected_with_the_camera_lands_on_the_hit_triangle(atrium):
    camera = rayfold.Camera.look_at(eye=(-12.0, 4.0, 6.0), target=(3.0, 1.5, -2.0), up=(0, 1, 0), vfov_deg=55,
                                    width=120, height=70)
    g = atrium.render(camera, fold="xy")
    assert reprojection_error(atrium, camera, g, min_hits=1000, step=7) < 1e-4


def test_matrix_cameras_in_both_conventions_equal_the_look_at_camera(atrium):
    a = atrium.default_camera(64, 40)
    g = atrium.render(a, fold="xy")
    fx, fy, cx, cy = a.intrinsics
    for convention in ["opencv", "opengl"]:
        b = rayfold.Camera.from_matrix(a.camera_to_world_in(convention), fx, fy, cx, cy, 64, 40,
                                       convention=convention)
        np.testing.assert_array_equal(b.camera_to_world, a.camera_to_world)
        assert_same_bits(g, atrium.render(b, fold="xy"))
    cv, gl = a.camera_to_world_in("opencv"), a.camera_to_world
    np.testing.assert_array_equal(cv[:, 1:3], -gl[:, 1:3])
    np.testing.assert_allclose(a.world_to_camera @ a.camera_to_world, np.eye(4), rtol=0, atol=1e-15)


def test_off_grid_principal_point_keeps_its_rays_and_drops_only_that_fold(atrium):
    base = atrium.default_camera(64, 40)
    c = rayfold.Camera.from_matrix(base.camera_to_world_in("opencv"), 70.0, 65.0, 30.3, 20.0, 64, 40,
                                   convention="opencv")
    assert not c.can_fold_columns and c.can_fold_rows
    g = atrium.render(c, fold="xy")
    assert g.fold == "x"
    assert_same_bits(atrium.render(c, backend="cpu"), g)
    # Pixel (x, y)'s ray is OpenCV's pinhole ray through (x + 0.5, y + 0.5).
    m = c.camera_to_world_in("opencv")
    for x, y in [(0, 0), (63, 39), (17, 5)]:
        d = m[:3, :3] @ np.array([(x + 0.5 - 30.3) / 70.0, (y + 0.5 - 20.0) / 65.0, 1.0])
        np.testing.assert_allclose(c.ray_directions()[y, x], d / np.linalg.norm(d), atol=1e-12)


def triangle_scene():
    s = rayfold.Scene()
    quad = s.add_mesh(np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32), [[0, 1, 2], [0, 2, 3]],
                      name="quad")
    s.add_instance(quad, np.eye(4), name="back")
    front = np.eye(4)
    front[:3, 3] = (0.5, 0.0, 1.0)
    s.add_instance(quad, np.diag([0.5, 0.5, 1.0, 1.0]) @ np.eye(4) + (front - np.eye(4)), name="front")
    return s


def hall_scene(length=5.0):
    """A closed box 2 * length long in x and 2 wide and high, every face wound
    to face inwards: a room seen from inside."""
    s = rayfold.Scene()
    corners = np.array([[x, y, z] for x in (-length, length) for y in (-1, 1) for z in (-1, 1)], np.float32)
    faces = []
    for axis in range(3):
        for side in (0, 1):
            quad = [i for i in range(8) if ((i >> (2 - axis)) & 1) == side]
            a, b, d, c = quad  # corners in a cycle: a b c d
            for tri in ([a, b, c], [a, c, d]):
                p = corners[tri]
                if np.dot(np.cross(p[1] - p[0], p[2] - p[0]), p.sum(axis=0)) > 0:
                    tri = [tri[0], tri[2], tri[1]]
                faces.append(tri)
    s.add_instance(s.add_mesh(corners, faces, name="hall"))
    return s


def test_the_default_camera_of_a_room_is_inside_looking_along_it():
    """Framed from outside, a room was a closed box; its default view is now
    from its centre along its length, as `rayfold render` chooses it."""
    hall = hall_scene()
    camera = hall.default_camera(32, 18)
    np.testing.assert_array_equal(camera.eye, (0.0, 0.0, 0.0))
    g = hall.render(camera)
    assert g.hits == 32 * 18
    assert g.depth[9, 16] > 4.9, "the centre pixel sees no end wall: not looking along the hall"


def test_moving_an_instance_equals_a_scene_built_with_it_there():
    camera = rayfold.Camera.look_at((0.3, 0.2, 5.0), (0, 0, 0), (0, 1, 0), 45, 50, 40)
    moving = triangle_scene()
    renderer = rayfold.Renderer(moving, backend="opencl")
    first = renderer.render(camera, "xy")
    assert set(np.unique(first.instance_id)) == {0, 1, rayfold.MISS}
    for step in range(3):
        m = moving.transform(1)
        m[:3, 3] += (-0.3, 0.1 * step, 0.2)
        moving.set_transform(1, m)
        fresh = triangle_scene()
        fresh.set_transform(1, m)
        assert_same_bits(rayfold.Renderer(fresh, backend="cpu").render(camera, "xy"), renderer.render(camera, "xy"))


def test_bad_input_raises_with_the_file_and_the_reason(tmp_path, atrium):
    with pytest.raises(rayfold.InputError, match="no_such.glb"):
        rayfold.Scene(tmp_path / "no_such.glb")
    broken = tmp_path / "broken.gltf"
    broken.write_text('{"asset": {"version": "2.0"}, "meshes": {"not": "an array"}}')
    with pytest.raises(ValueError, match="broken.gltf"):
        rayfold.Scene(str(broken))
    camera = atrium.default_camera(8, 8)
    with pytest.raises(rayfold.InputError, match="fold must be"):
        atrium.render(camera, fold="z")
    with pytest.raises(rayfold.InputError, match="backend must be"):
        atrium.render(camera, backend="gpu")
    with pytest.raises(rayfold.InputError, match="4x4"):
        rayfold.Camera.from_matrix(np.eye(3), 10, 10, 4, 4, 8, 8, convention="opencv")
    with pytest.raises(rayfold.InputError, match="convention must be"):
        rayfold.Camera.from_matrix(np.eye(4), 10, 10, 4, 4, 8, 8, convention="directx")
    with pytest.raises(TypeError):
        rayfold.Camera.from_matrix(np.eye(4), 10, 10, 4, 4, 8, 8)  # the convention must be named
    with pytest.raises(rayfold.InputError, match="orthonormal"):
        rayfold.Camera.from_matrix(np.diag([2.0, 1, 1, 1]), 10, 10, 4, 4, 8, 8, convention="opencv")
    with pytest.raises(rayfold.InputError, match="distinct"):
        rayfold.Camera.look_at((0, 0, 0), (0, 0, 0), (0, 1, 0), 60, 8, 8)
    with pytest.raises(rayfold.InputError, match="out of range"):
        rayfold.Camera.look_at((0, 0, 1), (0, 0, 0), (0, 1, 0), 60, 0, 8)
    s = rayfold.Scene()
    with pytest.raises(rayfold.InputError, match="shape"):
        s.add_mesh(np.zeros((4, 2)), [0, 1, 2])
    with pytest.raises(rayfold.InputError, match="4 vertices"):
        s.add_mesh(np.zeros((4, 3)), [0, 1, 4])
    with pytest.raises(rayfold.InputError, match="not a vertex index"):
        s.add_mesh(np.zeros((4, 3)), [0, 1, -1])
    with pytest.raises(rayfold.InputError, match="not an array of numbers"):
        s.add_mesh("abc", [0, 1, 2])
    with pytest.raises(rayfold.InputError, match="does not exist"):
        s.add_instance(5, np.eye(4))
    with pytest.raises(rayfold.RuntimeFailure, match="no OpenCL device matches"):
        rayfold.Renderer(atrium, device="no such device")
    assert issubclass(rayfold.InputError, ValueError) and issubclass(rayfold.RuntimeFailure, RuntimeError)


def test_rendering_releases_the_gil(atrium):
    camera = atrium.default_camera(1280, 720)
    atrium.render(camera, backend="cpu", threads=1)  # trees built before timing
    done = threading.Event()

    def work():
        for _ in range(3):
            atrium.render(camera, backend="cpu", threads=1)
        done.set()

    t = threading.Thread(target=work)
    start = time.perf_counter()
    t.start()
    spins = 0
    while not done.is_set():
        spins += 1
    t.join()
    # With the GIL held for the renders, this loop would get a few turns
    # between them; released, it runs the whole time.
    assert spins > 10000, (spins, time.perf_counter() - start)


def test_set_time_plays_the_file_animation_as_loading_at_that_time(atrium_path):
    import pathlib

    path = pathlib.Path(__file__).resolve().parents[1] / "fuzz" / "corpus" / "animated.gltf"
    scene = rayfold.Scene(path)
    assert scene.animated and scene.animation_end > 0
    camera = scene.default_camera(40, 30)
    renderer = rayfold.Renderer(scene, backend="opencl")
    depths = []
    for t in [0.0, 0.3 * scene.animation_end, scene.animation_end, 0.1]:
        scene.set_time(t)
        g = renderer.render(camera, "xy")
        assert_same_bits(rayfold.Scene(path, time=t).render(camera, fold="xy", backend="cpu"), g)
        depths.append(g.depth)
    assert not np.array_equal(depths[0], depths[2]), "the animation moves something in view" 
    with pytest.raises(rayfold.InputError, match="not loaded from a file"):
        rayfold.Scene().set_time(1.0)


def test_orthographic_camera_reprojects_folds_losslessly_and_matches_the_cli(atrium, atrium_path, cli, tmp_path):
    openexr = pytest.importorskip("OpenEXR")
    camera = rayfold.Camera.orthographic(eye=(-25.0, 20.0, 15.0), target=(0, 0, 0), up=(0, 1, 0), half_height=12.0,
                                         width=72, height=48)
    assert camera.is_orthographic
    g = atrium.render(camera, fold="xy")
    assert g.fold == "xy"
    assert_same_bits(atrium.render(camera, backend="cpu"), g)
    dirs, origins = camera.ray_directions(), camera.ray_origins()
    np.testing.assert_allclose(dirs - dirs[0, 0], 0, atol=1e-15)  # parallel rays
    # Depths here are from the image plane, so a few units: relative to them
    # the float positions of the plane's points (tens of units) count more.
    assert reprojection_error(atrium, camera, g, min_hits=500, step=11) < 1e-3
    ys, xs = np.nonzero(g.instance_id != rayfold.MISS)
    out = tmp_path / "ortho.exr"
    subprocess.run([cli, "render", atrium_path, "--size", "72x48", "--eye", "-25,20,15", "--look-at", "0,0,0",
                    "--ortho", "12", "--fold", "xy", "-o", str(out), "-q"], check=True)
    exr = openexr.File(str(out))
    np.testing.assert_array_equal(bits(exr.channels()["Z"].pixels), bits(g.depth))
    h = exr.header()
    assert h["rayfold:projection"] == "orthographic"
    for y, x in zip(ys[::97], xs[::97]):
        p = origins[y, x] + g.depth[y, x] * dirs[y, x]
        ndc = np.append(p, 1.0) @ h["worldToNDC"].astype(np.float64)
        assert abs(ndc[0] / ndc[3] * 72 - (x + 0.5)) < 1e-2 and abs(ndc[1] / ndc[3] * 48 - (y + 0.5)) < 1e-2


def test_the_readme_python_lines_run_as_written():
    import run_readme

    run_readme.run()


def _pool_results(method, args, timeout=120):
    import multiprocessing

    import fork_worker

    with multiprocessing.get_context(method).Pool(2) as pool:
        return pool.map_async(fork_worker.render_hits, args).get(timeout=timeout)


@pytest.mark.parametrize("method", ["spawn", "forkserver", "fork"])
def test_workers_after_the_parent_rendered_never_hang(atrium_path, method):
    """A forked child of a process that used OpenCL used to wait forever in
    PoCL's dead worker threads; it now fails at once naming the remedy, and
    its CPU backend works. Spawned and forkserver workers render as the
    parent does. (get() times out instead of hanging.)"""
    parent = rayfold.Scene(atrium_path)
    expected = parent.render(parent.default_camera(48, 27), fold="xy").depth.tobytes()
    results = _pool_results(method, [(atrium_path, "opencl"), (atrium_path, "cpu")])
    assert results[1] == ("ok", expected), results[1]
    if method == "fork":
        kind, message = results[0]
        assert kind == "RuntimeFailure", results[0]
        assert "is a fork of it" in message and "'spawn'" in message and "backend='cpu'" in message, message
    else:
        assert results[0] == ("ok", expected), results[0][0]


def test_python_threads_render_side_by_side(atrium):
    """Threads sharing one scene and threads with their own give the bits of
    one render alone (the GIL is released while tracing)."""
    camera = atrium.default_camera(48, 27)
    expected = atrium.render(camera, fold="xy")
    own = [rayfold.Scene(atrium.path) for _ in range(2)]
    results, errors = {}, []

    def work(key, scene):
        try:
            for _ in range(3):
                results[key] = scene.render(camera, fold="xy")
        except Exception as e:  # reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(f"shared{k}", atrium)) for k in range(2)]
    threads += [threading.Thread(target=work, args=(f"own{k}", s)) for k, s in enumerate(own)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
    assert not any(t.is_alive() for t in threads), "a rendering thread hung"
    assert not errors, errors
    assert len(results) == 4
    for g in results.values():
        assert_same_bits(g, expected)


def test_unnamed_nodes_are_node_n_in_instance_names(tmp_path):
    """The docs promise "node N" for unnamed nodes; they were ""."""
    import base64
    import json

    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], dtype=np.float32).tobytes()
    gltf = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": "data:application/octet-stream;base64," + base64.b64encode(positions).decode(),
                     "byteLength": len(positions)}],
        "bufferViews": [{"buffer": 0, "byteLength": len(positions)}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "nodes": [{"mesh": 0, "name": "named"}, {"mesh": 0, "translation": [2, 0, 0]}],
        "scenes": [{"nodes": [0, 1]}],
    }
    path = tmp_path / "unnamed.gltf"
    path.write_text(json.dumps(gltf))
    assert rayfold.Scene(str(path)).instance_names == ["named", "node 1"]


def test_intersect_from_camera_rays_finds_the_render_hits(atrium):
    """Rays from camera.ray_directions() against the camera's own render: the
    same triangle but where the rounded double direction is another float ray
    than the render's (edges), t the depth within a few roundings."""
    camera = atrium.default_camera(160, 90)
    g = atrium.render(camera, backend="cpu")
    d = camera.ray_directions()
    o = np.broadcast_to(camera.ray_origins(), d.shape)
    h = atrium.intersect(o, d, backend="opencl")
    assert h["t"].shape == (90, 160) and h["normal"].shape == (90, 160, 3) and h["uv"].shape == (90, 160, 2)
    assert h["t"].dtype == np.float32 and h["instance_id"].dtype == np.uint32
    same = (h["instance_id"] == g.instance_id) & (h["primitive_id"] == g.primitive_id)
    assert same.mean() > 0.99
    hit = same & (g.instance_id != rayfold.MISS)
    assert hit.sum() > 1000
    assert np.max(np.abs(h["t"][hit] - g.depth[hit]) / g.depth[hit]) < 1e-4
    np.testing.assert_array_equal(h["normal"][hit & (h["uv"][..., 0] == g.uv[..., 0])],
                                  g.normal[hit & (h["uv"][..., 0] == g.uv[..., 0])])
    cpu = atrium.intersect(o, d, backend="cpu")
    for k in h:
        np.testing.assert_array_equal(bits(cpu[k]), bits(h[k]), err_msg=k)
    occluded = atrium.occluded(o, d)
    assert occluded.dtype == np.bool_
    np.testing.assert_array_equal(occluded, h["instance_id"] != rayfold.MISS)


def test_intersect_fills_the_channels_asked_for(atrium):
    """channels names the planes filled, each the bits of a full query; the
    others are None; an unknown name is an error."""
    camera = atrium.default_camera(64, 36)
    d = camera.ray_directions()
    o = np.broadcast_to(camera.ray_origins(), d.shape)
    full = atrium.intersect(o, d)
    assert (full["instance_id"] != rayfold.MISS).sum() > 500
    for channels in (["t"], "t,instance_id", ["normal", "uv"], "primitive_id", ["depth"]):
        h = atrium.intersect(o, d, channels=channels)
        names = channels.split(",") if isinstance(channels, str) else channels
        names = ["t" if n == "depth" else n for n in names]
        for k in full:
            if k in names:
                np.testing.assert_array_equal(bits(h[k]), bits(full[k]), err_msg=f"{k} of {channels}")
            else:
                assert h[k] is None, (k, channels)
    with pytest.raises(rayfold.InputError, match="unknown channel 'z'"):
        atrium.intersect(o, d, channels="t,z")


def test_intersect_memory_is_its_arrays_whatever_the_ray_count(atrium_path):
    """Rays go through in chunks of 2^20: from 2^20 to 2^23 rays the peak
    grows by the arrays in and out (56 bytes a ray), not by the 64 bytes a
    ray of trace-space rays and answers that unchunked queries would add."""
    worker = Path(__file__).with_name("intersect_worker.py")
    runs = []
    for n in (1 << 20, 1 << 23):
        out = subprocess.run([sys.executable, str(worker), atrium_path, str(n)], capture_output=True, text=True,
                             timeout=600, check=True)
        runs.append(json.loads(out.stdout))
    small, big = runs
    assert big["hits"] > big["rays"] // 2, big
    grown, arrays = big["peak"] - small["peak"], big["arrays"] - small["arrays"]
    assert grown < arrays + (24 << 20), (grown, arrays, runs)


def test_intersect_rules_and_bad_rays():
    s = triangle_scene()  # the back quad at z = 0, facing +z
    o = np.array([[-0.8, 0.0, 3.0]])
    h = s.intersect(o, [[0.0, 0.0, -2.0]], backend="cpu")
    assert h["t"][0] == 1.5 and h["instance_id"][0] == 0  # t along the direction as given
    assert s.intersect(o, [[0.0, 0.0, -1.0]], tmax=2.9)["instance_id"][0] == rayfold.MISS
    assert s.intersect(o, [[0.0, 0.0, -1.0]], tmax=3.0)["t"][0] == 3.0
    assert not s.occluded(o, [[0.0, 0.0, -1.0]], tmin=3.0)[0]
    read_only = np.array([[-0.8, 0.0, 3.0]], np.float64)
    read_only.setflags(write=False)
    assert s.intersect(read_only, np.array([[0.0, 0.0, -1.0]]))["t"][0] == 3.0
    assert s.intersect(np.zeros((0, 3)), np.zeros((0, 3)))["t"].shape == (0,)
    with pytest.raises(rayfold.InputError, match="ray 1: direction is zero"):
        s.intersect([[0, 0, 1], [0, 0, 1]], [[0, 0, -1], [0, 0, 0]])
    with pytest.raises(rayfold.InputError, match="ray 0: origin is not finite"):
        s.occluded([[np.nan, 0, 1]], [[0, 0, -1]])
    with pytest.raises(rayfold.InputError, match="shape"):
        s.intersect([[0, 0, 1]], [[0, 0, -1], [0, 0, -1]])
    with pytest.raises(rayfold.InputError, match="tmin"):
        s.intersect([[0, 0, 1]], [[0, 0, -1]], tmin=2.0, tmax=1.0)


def test_intersect_takes_open3d_style_rays_and_add_instance_defaults_to_where_the_mesh_is():
    s = triangle_scene()
    rng = np.random.default_rng(5)
    o = np.concatenate([rng.uniform(-1, 1, (64, 2)), np.full((64, 1), 3.0)], axis=1)
    d = np.concatenate([rng.uniform(-0.3, 0.3, (64, 2)), np.full((64, 1), -1.0)], axis=1)
    apart = s.intersect(o, d, backend="cpu")
    together = s.intersect(np.concatenate([o, d], axis=1), backend="cpu")  # (N, 6), as Open3D's cast_rays
    assert (apart["instance_id"] != rayfold.MISS).any()
    for k in ("t", "instance_id", "primitive_id", "uv", "normal"):
        assert np.array_equal(apart[k], together[k]), k
    image = np.concatenate([o, d], axis=1).reshape(8, 8, 6)
    assert s.intersect(image, backend="cpu")["t"].shape == (8, 8)
    assert np.array_equal(s.occluded(np.concatenate([o, d], axis=1), backend="cpu"), s.occluded(o, d, backend="cpu"))
    with pytest.raises(rayfold.InputError, match=r"rays given alone must have shape \(\.\.\., 6\).*not \(64, 3\)"):
        s.intersect(o)
    with pytest.raises(rayfold.InputError, match="rays is not an array of numbers"):
        s.intersect("rays")

    # An instance without a transform stands where its mesh is, as with the identity.
    a, b = rayfold.Scene(), rayfold.Scene()
    tri = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], np.float32)
    a.add_instance(a.add_mesh(tri, [[0, 1, 2]]), name="tri")
    b.add_instance(b.add_mesh(tri, [[0, 1, 2]]), np.eye(4), name="tri")
    assert np.array_equal(a.transform(0), np.eye(4))
    ray = np.array([[0.1, 0.0, 2.0, 0.0, 0.0, -1.0]])
    assert np.array_equal(a.intersect(ray, backend="cpu")["t"], b.intersect(ray, backend="cpu")["t"])
    assert a.intersect(ray, backend="cpu")["t"][0] == 2.0


def test_intersect_warns_of_instances_it_cannot_trace():
    s = rayfold.Scene()
    cube = s.add_mesh(np.array([[-1, -1, -1], [1, -1, -1], [0, 1, -1]], np.float32), [[0, 1, 2]])
    s.add_instance(cube, np.diag([2.0 ** 120] * 3 + [1.0]))
    s.add_instance(cube, np.diag([2.0 ** -140] * 3 + [1.0]))
    with pytest.warns(RuntimeWarning, match="1 instances not traced"):
        s.intersect([[0, 0, 0]], [[0, 0, -1]], backend="cpu")
    with pytest.warns(RuntimeWarning, match="1 instances not traced"):
        s.occluded([[0, 0, 0]], [[0, 0, -1]], backend="cpu")


def write_quad_gltf(path):
    """A bent quad with unit NORMALs, TEXCOORD_0 and material 1, placed turned
    and scaled; returns (positions, normals, texcoords, indices, world_from_object)."""
    import json
    p = np.array([[-1, -1, 0], [1, -1, 0.25], [1, 1, 0], [-1, 1, 0]], np.float32)
    n = np.array([[0.2, 0.1, 1], [-0.3, 0.2, 1], [0.1, -0.4, 1], [0, 0.3, 1]], np.float64)
    n = (n / np.linalg.norm(n, axis=1, keepdims=True)).astype(np.float32)
    t = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    idx = np.array([0, 1, 2, 0, 2, 3], np.uint32)
    blob = p.tobytes() + n.tobytes() + t.tobytes() + idx.tobytes()
    views = [(0, 48), (48, 48), (96, 32), (128, 24)]
    doc = {
        "asset": {"version": "2.0"},
        "buffers": [{"uri": path.name + ".bin", "byteLength": len(blob)}],
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": b} for o, b in views],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": p.min(0).tolist(), "max": p.max(0).tolist()},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"},
        ],
        "materials": [{"name": "a"}, {"name": "b"}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                    "indices": 3, "material": 1}]}],
        "nodes": [{"mesh": 0, "translation": [0.2, -0.1, -4], "scale": [1.5, 0.75, 1.2]}],
    }
    (path.parent / (path.name + ".bin")).write_bytes(blob)
    path.write_text(json.dumps(doc))
    m = np.diag([1.5, 0.75, 1.2, 1.0])
    m[:3, 3] = [0.2, -0.1, -4]
    return p, n, t, idx.reshape(-1, 3), m


def test_resolved_planes_equal_a_float64_resolve_of_the_file(tmp_path):
    path = tmp_path / "quad.gltf"
    p, n, t, tris, m = write_quad_gltf(path)
    scene = rayfold.Scene(str(path))
    camera = rayfold.Camera.look_at((0, 0, 0), (0, 0, -4), (0, 1, 0), 60.0, 64, 48)
    g = scene.render(camera, channels="depth,barycentrics,instance_id,primitive_id,shading_normal,texcoord,"
                                       "position,object_position,material_id")
    assert g.normal is None and g.texcoord1 is None
    np.testing.assert_array_equal(bits(g.uv), bits(g.barycentrics))  # the older name, kept
    hit = g.instance_id != rayfold.MISS
    assert hit.sum() > 500
    assert (g.material_id[hit] == 1).all() and (g.material_id[~hit] == rayfold.MISS).all()
    assert (g.position[~hit] == 0).all()
    v = tris[g.primitive_id[hit]]  # (K, 3) vertex indices
    bary = g.barycentrics[hit].astype(np.float64)
    w = np.stack([1 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1]], axis=1)[:, :, None]
    obj = (w * p[v].astype(np.float64)).sum(axis=1)
    world = obj @ m[:3, :3].T + m[:3, 3]
    ns = (w * n[v].astype(np.float64)).sum(axis=1) @ np.linalg.inv(m[:3, :3])
    ns /= np.linalg.norm(ns, axis=1, keepdims=True)
    uv = (w * t[v].astype(np.float64)).sum(axis=1)
    tol = dict(rtol=2 * 2.0**-24, atol=2 * 2.0**-24)
    np.testing.assert_allclose(g.object_position[hit], obj, **tol)
    np.testing.assert_allclose(g.position[hit], world, rtol=2 * 2.0**-24, atol=8 * 2.0**-24)
    np.testing.assert_allclose(g.shading_normal[hit], ns, **tol)
    np.testing.assert_allclose(g.texcoord[hit], uv, **tol)
    # The position is on the pixel's ray at its depth.
    along = camera.ray_directions()[hit] * g.depth[hit][:, None]
    np.testing.assert_allclose(g.position[hit], along, atol=1e-5)
    # Written and read back, every plane bit for bit.
    g.write_exr(tmp_path / "quad.exr", scene)
    back = rayfold.read_exr(tmp_path / "quad.exr")
    for name in ["depth", "barycentrics", "instance_id", "shading_normal", "texcoord", "position",
                 "object_position", "material_id"]:
        np.testing.assert_array_equal(bits(back[name]), bits(getattr(g, name)), err_msg=name)
    assert "normal" not in back and "texcoord1" not in back


def test_material_planes_and_labels_from_the_file(tmp_path):
    import json
    path = tmp_path / "quad.gltf"
    write_quad_gltf(path)
    doc = json.loads(path.read_text())
    doc["materials"][1].update({
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.5, 0.25, 0.75], "metallicFactor": 0.2,
                                 "roughnessFactor": 0.6},
        "emissiveFactor": [0.1, 0.2, 0.3]})
    doc["nodes"] = [{"children": [1], "extras": {"category": "floor", "note": "tiles"}}, dict(doc["nodes"][0])]
    path.write_text(json.dumps(doc))
    scene = rayfold.Scene(str(path), label_key="category")
    camera = rayfold.Camera.look_at((0, 0, 0), (0, 0, -4), (0, 1, 0), 60.0, 64, 48)
    g = scene.render(camera, channels="instance_id,base_color,metallic_roughness,emissive,label")
    hit = g.instance_id != rayfold.MISS
    assert hit.sum() > 500
    assert scene.labels == ["", "floor"]
    assert (g.label[hit] == 1).all() and (g.label[~hit] == rayfold.MISS).all()
    want = {"base_color": [0.9, 0.5, 0.25, 0.75], "metallic_roughness": [0.2, 0.6], "emissive": [0.1, 0.2, 0.3]}
    for name, value in want.items():
        plane = getattr(g, name)
        np.testing.assert_array_equal(plane[hit], np.broadcast_to(np.float32(value), plane[hit].shape), err_msg=name)
        assert (plane[~hit] == 0).all(), name
    # The whole extras value without a key; the planes through an EXR, bit for bit.
    assert rayfold.Scene(str(path)).labels == ["", '{"category":"floor","note":"tiles"}']
    # The header turns a saved view back into points and names.
    g2 = scene.render(camera, channels="depth,instance_id,position,label")
    g2.write_exr(tmp_path / "points.exr", scene)
    header = rayfold.read_exr_header(tmp_path / "points.exr")
    planes = rayfold.read_exr(tmp_path / "points.exr")
    assert (header["width"], header["height"], header["depth_kind"]) == (64, 48, "distance")
    assert header["labels"] == ["", "floor"] and len(header["instance_names"]) == 1
    c = header["camera"]
    points = (c.ray_origins() + planes["depth"][..., None] * c.ray_directions())[hit]
    np.testing.assert_allclose(points, g2.position[hit], rtol=1e-5, atol=1e-5)
    g.write_exr(tmp_path / "quad.exr", scene)
    back = rayfold.read_exr(tmp_path / "quad.exr")
    for name in ["base_color", "metallic_roughness", "emissive", "label"]:
        np.testing.assert_array_equal(bits(back[name]), bits(getattr(g, name)), err_msg=name)


def test_flow_to_another_camera_is_the_projection_of_each_hit(tmp_path):
    path = tmp_path / "quad.gltf"
    write_quad_gltf(path)
    scene = rayfold.Scene(str(path))
    a = rayfold.Camera.look_at((0, 0, 0), (0, 0, -4), (0, 1, 0), 60.0, 64, 48)
    b = rayfold.Camera.look_at((0.5, 0.3, 0.2), (0.1, 0, -4), (0, 1, 0), 50.0, 80, 60)
    g = scene.render(a, channels="depth,instance_id,flow,flow_visible", flow_to=b)
    hit = g.instance_id != rayfold.MISS
    assert hit.sum() > 500
    # Each hit's point from its ray and depth, into b by its pose and intrinsics (pixel centres at integers).
    points = (a.ray_origins() + g.depth[..., None] * a.ray_directions())[hit]
    w2c = np.linalg.inv(b.camera_to_world_in("opencv"))
    cam = points @ w2c[:3, :3].T + w2c[:3, 3]
    fx, fy, cx, cy = b.intrinsics
    at = np.stack([fx * cam[:, 0] / cam[:, 2] + cx - 0.5, fy * cam[:, 1] / cam[:, 2] + cy - 0.5], 1)
    ys, xs = np.nonzero(hit)
    np.testing.assert_allclose(g.flow[hit], at - np.stack([xs, ys], 1), atol=2e-3)
    assert set(np.unique(g.flow_visible[hit])) <= {0, 1} and (g.flow_visible[~hit] == rayfold.MISS).all()
    # (camera, time) on a file without animations: the same pose, the same bits; flow needs flow_to.
    same = scene.render(a, channels="depth,instance_id,flow,flow_visible", flow_to=(b, 0.0), time=0.0)
    np.testing.assert_array_equal(bits(same.flow), bits(g.flow))
    with pytest.raises(ValueError, match="flow_to"):
        scene.render(a, channels="flow")
    listed = scene.render(a, channels="depth,instance_id,flow,flow_visible", flow_to=[b, None])
    np.testing.assert_array_equal(bits(listed.flow), bits(g.flow))
    for bad, why in [((b, "soon"), "time must be a finite number"), ("b", "Camera or \\(Camera, time\\)"),
                     ((b, 0.0, 1.0), "Camera or")]:
        with pytest.raises(ValueError, match=why):
            scene.render(a, channels="flow", flow_to=bad)
    with pytest.raises(ValueError, match="neither flow nor flow_visible"):
        scene.render(a, channels="depth", flow_to=b)


def test_a_list_of_views_flows_from_each_to_the_next(tmp_path, cli):
    path = tmp_path / "quad.gltf"
    write_quad_gltf(path)
    scene = rayfold.Scene(str(path))
    # 40 views: iter_views reads 32 at a time, so one flows across its chunks.
    cameras = [rayfold.Camera.look_at((0.01 * k, 0.005 * k, 0), (0.2, -0.1, -4), (0, 1, 0), 60.0, 48, 32)
               for k in range(40)]
    channels = "depth,instance_id,flow,flow_visible"
    streamed = list(scene.iter_views(cameras, fold="xy", channels=channels))
    listed = scene.render_views(cameras, fold="xy", channels=channels)
    for k in (0, 30, 31, 32, 38):
        want = scene.render(cameras[k], fold="xy", channels=channels, flow_to=cameras[k + 1])
        for g in (streamed[k], listed[k]):
            np.testing.assert_array_equal(bits(g.flow), bits(want.flow), err_msg=f"view {k}")
            np.testing.assert_array_equal(g.flow_visible, want.flow_visible, err_msg=f"view {k}")
    # The last view has none to go to.
    last = streamed[-1]
    hit = last.instance_id != rayfold.MISS
    assert hit.sum() > 150 and np.isnan(last.flow[hit]).all() and (last.flow_visible[hit] == 0).all()
    np.testing.assert_array_equal(bits(listed[-1].flow), bits(last.flow))
    # The CLI's camera lists write the same flow into each view's EXR.
    frames = [{"file_path": f"v{k}", "transform_matrix": c.camera_to_world_in("opengl").tolist()}
              for k, c in enumerate(cameras[:3])]
    fx = cameras[0].intrinsics[0]
    (tmp_path / "t.json").write_text(json.dumps({"fl_x": fx, "fl_y": fx, "cx": 24.0, "cy": 16.0, "w": 48, "h": 32,
                                                 "frames": frames}))
    subprocess.run([cli, "render", str(path), "-q", "--cameras", str(tmp_path / "t.json"), "--channels",
                    "Z,InstanceID,Flow,FlowVisible", "-o", str(tmp_path / "%s.exr")], check=True)
    for k in range(2):
        back = rayfold.read_exr(tmp_path / f"v{k}.exr")
        np.testing.assert_array_equal(bits(back["flow"]), bits(listed[k].flow), err_msg=f"view {k}")
    back = rayfold.read_exr(tmp_path / "v2.exr")  # the file's last view
    assert np.isnan(back["flow"][back["instance_id"] != rayfold.MISS]).all()
    single = subprocess.run([cli, "render", str(path), "-q", "--channels", "flow", "-o", str(tmp_path / "x.exr")],
                            capture_output=True, text=True)
    assert single.returncode == 2 and "a single view has none to go to" in single.stderr, single.stderr


def test_opencl_devices_lists_what_the_cli_lists(cli):
    """rayfold.opencl_devices() and `rayfold devices` name the same devices (one public call under both); in a
    process of its own, since listing is this process's first use of OpenCL."""
    listed = subprocess.run([sys.executable, "-c", "import json, rayfold; print(json.dumps(rayfold.opencl_devices()))"],
                            capture_output=True, text=True, check=True, env=os.environ)
    devices = json.loads(listed.stdout)
    assert devices and all(": " in d for d in devices), devices
    printed = subprocess.run([cli, "devices"], capture_output=True, text=True, check=True).stdout
    assert [line.strip() for line in printed.splitlines()[1:] if line.strip()] == devices
