"""rayfold-batch on Ray's local cluster, which each run starts and stops
itself: every view bit-identical to render_views, a worker killed mid-run,
resume, failures by view, bad input, flat memory."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import rayfold

ray = pytest.importorskip("ray", reason="rayfold.batch needs Ray (tools/scripts/python-env.sh installs it for make test)")
import rayfold.batch  # noqa: E402

PLANES = ("depth", "normal", "uv", "instance_id", "primitive_id")


def camera_list(path, count, width=64, height=48, intrinsics_every=0):
    """count views around the atrium; every intrinsics_every-th with its own
    fx, fy, cx, cy (a second group of intrinsics)."""
    cams = []
    for i in range(count):
        c = {"eye": [(0.37 * i) % 3 - 1.5, 1.0 + (0.13 * i) % 0.8, 4.5], "look_at": [0, 1, 0]}
        if intrinsics_every and i % intrinsics_every == 0:
            c.update(fx=0.9 * height, fy=0.9 * height, cx=width / 2, cy=height / 2)
        cams.append(c)
    with open(path, "w") as f:
        json.dump({"width": width, "height": height, "cameras": cams}, f)
    return rayfold.Camera.from_file(path)[0]


def batch_cli(atrium_path, *args, timeout=600):
    return subprocess.run([sys.executable, "-m", "rayfold.batch", atrium_path, *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def summary(path):
    with open(path) as f:
        return json.load(f)


def assert_views_equal(scene, cameras, pattern, fold, indices=None):
    expected = scene.render_views(cameras, fold=fold)
    for i in (range(len(cameras)) if indices is None else indices):
        got = rayfold.read_exr(pattern % i)
        for p in PLANES:
            assert got[p].tobytes() == getattr(expected[i], p).tobytes(), f"view {i}, plane {p}"


def test_every_view_equals_render_views_from_python_and_the_cli(atrium_path, tmp_path, cli):
    scene = rayfold.Scene(atrium_path)
    cameras = camera_list(tmp_path / "c.json", 70, intrinsics_every=3)
    pattern = str(tmp_path / "py" / "v_%04d.exr")
    os.makedirs(tmp_path / "py")
    s = rayfold.batch.render(atrium_path, cameras, pattern, workers=2, fold="xy", progress=False)
    assert (s.rendered, s.kept, s.failed, s.workers_lost) == (70, 0, [], 0)
    assert_views_equal(scene, cameras, pattern, "xy")
    # The CLI, from the camera file, against rayfold render of the same list.
    os.makedirs(tmp_path / "cli")
    r = batch_cli(atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "cli" / "v_%04d.exr",
                  "--fold", "y", "--channels", "depth,instance_id", "--workers", "1", "-q", "--send", "trees")
    assert r.returncode == 0, r.stderr
    assert "70 of 70 views written" in r.stderr, r.stderr
    os.makedirs(tmp_path / "render")
    subprocess.run([cli, "render", atrium_path, "-q", "--cameras", tmp_path / "c.json", "-o",
                    tmp_path / "render" / "v_%04d.exr"], check=True)
    for i in range(70):
        got = rayfold.read_exr(tmp_path / "cli" / f"v_{i:04d}.exr")
        assert sorted(got) == ["depth", "instance_id"]
        want = rayfold.read_exr(tmp_path / "render" / f"v_{i:04d}.exr")
        for p in ("depth", "instance_id"):
            assert got[p].tobytes() == want[p].tobytes(), f"view {i}, plane {p}"


def test_a_scene_built_in_memory_and_moved_reaches_the_workers_as_trees(tmp_path):
    scene = rayfold.Scene()
    mesh = scene.add_mesh(np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0], [0, 0, 1]], np.float32),
                          np.array([[0, 1, 2], [0, 1, 3], [1, 2, 3]], np.uint32))
    for k in range(5):
        scene.add_instance(mesh, np.array([[1, 0, 0, 2.5 * k - 5], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    scene.render(rayfold.Camera.look_at((0, 0, 9), (0, 0, 0), (0, 1, 0), 60, 16, 16))  # trees built
    scene.set_transform(2, np.array([[0, -1, 0, 0], [1, 0, 0, 1], [0, 0, 1, 0.5], [0, 0, 0, 1]]))  # and moved
    cameras = [rayfold.Camera.look_at((0.3 * k - 1, 0.5, 9), (0, 0, 0), (0, 1, 0), 60, 48, 32) for k in range(9)]
    pattern = str(tmp_path / "v_%d.exr")
    s = rayfold.batch.render(scene, cameras, pattern, workers=2, fold="xy", progress=False)
    assert (s.rendered, s.failed) == (9, [])
    assert_views_equal(scene, cameras, pattern, "xy")
    with pytest.raises(rayfold.InputError, match="needs the scene's path"):
        rayfold.batch.render(scene, cameras, pattern, send="file")
    # Built in memory, it has its stand-ins in its own renders too: the same bits, not refused.
    s = rayfold.batch.render(scene, cameras[:2], str(tmp_path / "m_%d.exr"), channels="material_id,instance_id",
                             progress=False)
    assert (s.rendered, s.failed) == (2, [])
    for i, g in enumerate(scene.render_views(cameras[:2], channels="material_id,instance_id")):
        assert rayfold.read_exr(tmp_path / f"m_{i}.exr")["material_id"].tobytes() == g.material_id.tobytes()


def test_flow_goes_from_each_view_to_the_next_across_workers(atrium_path, tmp_path):
    scene = rayfold.Scene(atrium_path)
    cameras = camera_list(tmp_path / "c.json", 12, intrinsics_every=5)
    channels = "depth,instance_id,flow,flow_visible"
    pattern = str(tmp_path / "out" / "v_%d.exr")
    s = rayfold.batch.render(atrium_path, tmp_path / "c.json", pattern, workers=2, fold="xy", channels=channels,
                             progress=False)
    assert (s.rendered, s.failed) == (12, [])
    expected = scene.render_views(cameras, fold="xy", channels=channels)
    for i, e in enumerate(expected):
        got = rayfold.read_exr(pattern % i)
        for p in ("flow", "flow_visible", "depth"):
            assert got[p].tobytes() == getattr(e, p).tobytes(), f"view {i}, plane {p}"
    # A view moved: it and the view before it (which flows to it) are rendered again.
    moved = json.loads((tmp_path / "c.json").read_text())
    moved["cameras"][7]["eye"][0] += 0.25
    (tmp_path / "c.json").write_text(json.dumps(moved))
    s = rayfold.batch.render(atrium_path, tmp_path / "c.json", pattern, workers=2, fold="xy", channels=channels,
                             progress=False)
    assert (s.rendered, s.kept) == (2, 10)


def test_one_zarr_store_holds_every_views_bits_and_resumes(atrium_path, tmp_path):
    zarr = pytest.importorskip("zarr", reason="zarr stores need zarr (tools/scripts/python-env.sh installs it)")
    scene = rayfold.Scene(atrium_path)
    cameras = camera_list(tmp_path / "c.json", 20, intrinsics_every=4)
    store = tmp_path / "views.zarr"
    s = rayfold.batch.render(atrium_path, tmp_path / "c.json", store, workers=2, fold="xy",
                             channels="Z,InstanceID,normal,uv", progress=False)
    assert (s.rendered, s.failed) == (20, [])
    g = zarr.open_group(str(store), mode="r")
    # The barycentrics by the name that says what they hold, uv taken as their older name.
    assert sorted(g.keys()) == ["barycentrics", "depth", "instance_id", "normal"]
    assert "not texture coordinates" in g.attrs["barycentrics"]
    old = zarr.open_group(str(tmp_path / "old.zarr"), mode="w")  # a store of before the rename
    old.create_array("uv", shape=(1,), dtype="float32")
    with pytest.raises(rayfold.InputError, match="named the barycentrics uv"):
        rayfold.batch.render(atrium_path, tmp_path / "c.json", tmp_path / "old.zarr", channels="uv", progress=False)
    assert g["normal"].shape == (20, 48, 64, 3) and g["normal"].chunks == (1, 48, 64, 3)
    assert len(g.attrs["cameras"]) == 20 and g.attrs["instance_names"] == list(scene.instance_names)
    assert g.attrs["cameras"][4]["fx"] == cameras[4].intrinsics[0]
    expected = scene.render_views(cameras, fold="xy")
    for i, e in enumerate(expected):
        for p in ("depth", "instance_id", "normal", "barycentrics"):
            assert g[p][i].tobytes() == getattr(e, p).tobytes(), f"view {i}, plane {p}"
    # A chunk gone: that view is rendered again, the others kept.
    chunk = [p for p in (store / "depth").rglob("*") if p.is_file() and p.name != "zarr.json"][0]
    chunk.unlink()
    s = rayfold.batch.render(atrium_path, tmp_path / "c.json", store, fold="xy",
                             channels="Z,InstanceID,normal,uv", progress=False)
    assert (s.rendered, s.kept) == (1, 19)
    assert not list(store.rglob("*.partial"))
    for i, e in enumerate(expected):
        assert g["depth"][i].tobytes() == e.depth.tobytes(), f"view {i}"
    with pytest.raises(rayfold.InputError, match="another scene, cameras or options"):
        rayfold.batch.render(atrium_path, tmp_path / "c.json", store, fold="y", channels="Z,InstanceID,normal,uv",
                             progress=False)
    mixed = cameras[:2] + [rayfold.Camera.look_at((0, 1, 5), (0, 1, 0), (0, 1, 0), 60, 32, 24)]
    with pytest.raises(rayfold.InputError, match="views of one size"):
        rayfold.batch.render(atrium_path, mixed, tmp_path / "mixed.zarr", progress=False)


def test_a_killed_worker_has_its_views_retried_and_nothing_is_lost(atrium_path, tmp_path):
    scene = rayfold.Scene(atrium_path)
    cameras = camera_list(tmp_path / "c.json", 1500, 96, 72)
    os.makedirs(tmp_path / "out")
    pattern = str(tmp_path / "out" / "v_%05d.exr")
    p = subprocess.Popen([sys.executable, "-m", "rayfold.batch", atrium_path, "--cameras", tmp_path / "c.json",
                          "-o", pattern, "--workers", "2", "-q", "--summary", tmp_path / "s.json"],
                         stderr=subprocess.PIPE, text=True)
    manifest = tmp_path / "out" / rayfold.batch.MANIFEST_DIR
    victim = None
    deadline = time.monotonic() + 300
    while victim is None and time.monotonic() < deadline and p.poll() is None:
        for name in (os.listdir(manifest) if manifest.is_dir() else []):
            if os.path.getsize(manifest / name) > 0:  # this worker has written views: kill it mid-run
                victim = int(name.rsplit("-", 1)[1].split(".")[0])
                break
        time.sleep(0.05)
    assert victim is not None, "no worker wrote a view"
    os.kill(victim, signal.SIGKILL)
    _, err = p.communicate(timeout=600)
    assert p.returncode == 0, err
    s = summary(tmp_path / "s.json")
    assert s["workers_lost"] == 1, err
    assert s["written"] == 1500 and s["failed"] == [], err
    assert 0 < s["views_retried"] <= rayfold.batch.BATCH_VIEWS, err  # at most the batch it held
    assert sorted(os.listdir(tmp_path / "out")) == sorted(
        [f"v_{i:05d}.exr" for i in range(1500)] + [rayfold.batch.MANIFEST_DIR]), "a stray or missing file"
    assert_views_equal(scene, cameras, pattern, "none")


def raylets():
    return {int(p) for p in subprocess.run(["pgrep", "-f", "raylet"], capture_output=True, text=True).stdout.split()}


def test_a_stopped_driver_stops_its_cluster_and_a_rerun_finishes_the_job(atrium_path, tmp_path):
    camera_list(tmp_path / "c.json", 1200, 96, 72)
    os.makedirs(tmp_path / "out")
    before = raylets()
    p = subprocess.Popen([sys.executable, "-m", "rayfold.batch", atrium_path, "--cameras", tmp_path / "c.json",
                          "-o", tmp_path / "out" / "v_%05d.exr", "-q"], stderr=subprocess.PIPE, text=True)
    manifest = tmp_path / "out" / rayfold.batch.MANIFEST_DIR
    deadline = time.monotonic() + 300
    while p.poll() is None and time.monotonic() < deadline and not (
            manifest.is_dir() and any(os.path.getsize(manifest / n) for n in os.listdir(manifest))):
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 128 + signal.SIGTERM, err
    assert "stopped (SIGTERM); every view written so far is complete" in err, err
    deadline = time.monotonic() + 30
    while raylets() - before and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not raylets() - before, "the run's Ray cluster outlived it"
    r = batch_cli(atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "out" / "v_%05d.exr", "-q",
                  "--summary", tmp_path / "s.json")
    assert r.returncode == 0, r.stderr
    s = summary(tmp_path / "s.json")
    assert s["written"] == 1200 and s["kept"] > 0, s
    names = sorted(n for n in os.listdir(tmp_path / "out") if n != rayfold.batch.MANIFEST_DIR)
    assert names == [f"v_{i:05d}.exr" for i in range(1200)], "a stray or missing file"


def test_a_rerun_renders_only_what_is_missing_changed_or_damaged(atrium_path, tmp_path):
    cameras = camera_list(tmp_path / "c.json", 40)
    pattern = str(tmp_path / "v_%03d.exr")
    s = rayfold.batch.render(atrium_path, cameras, pattern, progress=False)
    assert s.rendered == 40
    os.remove(pattern % 3)
    os.remove(pattern % 17)
    with open(pattern % 5, "r+b") as f:  # same size, one bit changed
        f.seek(2000)
        b = f.read(1)
        f.seek(2000)
        f.write(bytes([b[0] ^ 1]))
    s = rayfold.batch.render(atrium_path, cameras, pattern, progress=False)
    assert (s.rendered, s.kept) == (3, 37)
    assert_views_equal(rayfold.Scene(atrium_path), cameras, pattern, "none")
    # Nothing to do: no cluster is started.
    s = rayfold.batch.render(atrium_path, cameras, pattern, progress=False)
    assert (s.rendered, s.kept, s.startup_seconds) == (0, 40, 0.0)
    # A record holds what its file shows: a moved camera renders that view
    # again, another fold (the same bits) every view.
    cameras[7] = rayfold.Camera.look_at((0.5, 1.5, 4.0), (0, 1, 0), (0, 1, 0), 50, 64, 48)
    s = rayfold.batch.render(atrium_path, cameras, pattern, progress=False)
    assert (s.rendered, s.kept) == (1, 39)
    s = rayfold.batch.render(atrium_path, cameras, pattern, fold="xy", progress=False)
    assert (s.rendered, s.kept) == (40, 0)
    assert_views_equal(rayfold.Scene(atrium_path), cameras, pattern, "none")
    # Another EXR compression writes every view again, uncompressed here,
    # with the same planes; then it is kept.
    zipped = os.path.getsize(pattern % 0)
    s = rayfold.batch.render(atrium_path, cameras, pattern, fold="xy", exr_compression="none", progress=False)
    assert (s.rendered, s.kept) == (40, 0)
    assert os.path.getsize(pattern % 0) > max(zipped, 64 * 48 * 32)
    assert_views_equal(rayfold.Scene(atrium_path), cameras, pattern, "none")
    s = rayfold.batch.render(atrium_path, cameras, pattern, fold="xy", exr_compression="none", progress=False)
    assert (s.rendered, s.kept) == (0, 40)


def test_the_newest_record_of_a_view_counts_whatever_its_part_file_is_named(atrium_path, tmp_path):
    # Part files are named by host and pid, which say nothing of when they
    # were written: an earlier run's file that sorts after a later one's must
    # not bring back the earlier run's records. (Found as a rare failure of
    # the rerun test above, when a worker's pid happened to sort first.)
    cameras = camera_list(tmp_path / "c.json", 6)
    pattern = str(tmp_path / "v_%03d.exr")
    assert rayfold.batch.render(atrium_path, cameras, pattern, progress=False).rendered == 6
    manifest = tmp_path / rayfold.batch.MANIFEST_DIR
    for k, earlier in enumerate(sorted(os.listdir(manifest))):
        os.rename(manifest / earlier, manifest / f"zzzz-{k}.jsonl")  # sorts after any host's
    s = rayfold.batch.render(atrium_path, cameras, pattern, exr_compression="none", progress=False)
    assert (s.rendered, s.kept) == (6, 0)
    s = rayfold.batch.render(atrium_path, cameras, pattern, exr_compression="none", progress=False)
    assert (s.rendered, s.kept) == (0, 6)
    assert_views_equal(rayfold.Scene(atrium_path), cameras, pattern, "none")


def test_a_view_that_cannot_be_written_is_named_and_the_rest_complete(atrium_path, tmp_path):
    camera_list(tmp_path / "c.json", 12)
    os.makedirs(tmp_path / "out" / "v_04.exr")  # a folder where view 4's file goes
    r = batch_cli(atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "out" / "v_%02d.exr", "-q",
                  "--summary", tmp_path / "s.json")
    assert r.returncode == 1, r.stderr
    assert "error: view 4: " in r.stderr and "v_04.exr" in r.stderr, r.stderr
    s = summary(tmp_path / "s.json")
    assert s["written"] == 11 and [f[0] for f in s["failed"]] == [4], s
    assert all(os.path.isfile(tmp_path / "out" / f"v_{i:02d}.exr") for i in range(12) if i != 4)


def test_views_whose_cameras_are_bad_are_named_and_the_rest_render(atrium_path, tmp_path):
    cameras = camera_list(tmp_path / "c.json", 8)
    with open(tmp_path / "c.json") as f:
        listing = json.load(f)
    listing["cameras"][2]["fov"] = 40  # a key rayfold does not read
    listing["cameras"][5] = {"eye": [0, 1, 0], "look_at": [0, 1, 0]}  # no direction
    with open(tmp_path / "c.json", "w") as f:
        json.dump(listing, f)
    os.makedirs(tmp_path / "out")
    r = batch_cli(atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "out" / "v_%d.exr", "-q",
                  "--summary", tmp_path / "s.json")
    assert r.returncode == 1, r.stderr
    assert 'error: view 2: ' in r.stderr and 'cameras[2]: unknown key "fov"' in r.stderr, r.stderr
    assert "error: view 5: " in r.stderr and "cameras[5]" in r.stderr, r.stderr
    s = summary(tmp_path / "s.json")
    assert (s["written"], [f[0] for f in s["failed"]]) == (6, [2, 5]), s
    good = [i for i in range(8) if i not in (2, 5)]
    assert sorted(os.listdir(tmp_path / "out")) == sorted([f"v_{i}.exr" for i in good] + ["rayfold-manifest"])
    expected = rayfold.Scene(atrium_path).render_views([cameras[i] for i in good])
    for g, i in zip(expected, good):
        assert rayfold.read_exr(tmp_path / "out" / f"v_{i}.exr")["depth"].tobytes() == g.depth.tobytes()


def test_bad_input_fails_first_naming_what_is_wrong(atrium_path, tmp_path):
    camera_list(tmp_path / "c.json", 3)
    cases = [
        ([tmp_path / "missing.glb", "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.exr"], "missing.glb"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v.exr"], "one integer field"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.png"], "end it in .exr"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "c.json" / "v_%d.exr"],
         "cannot make the output folder"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "%d" / "v.exr"], "file's name"),
        ([atrium_path, "--cameras", tmp_path / "nope.json", "-o", tmp_path / "v_%d.exr"], "nope.json"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.exr", "--workers", "0"], "workers"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.exr", "--gpu-workers", "1"],
         "the Ray cluster has 0 GPUs"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v.zarr", "--exr-compression", "none"],
         "is for EXR outputs"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.exr", "--exr-compression", "b44"],
         "invalid choice"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.exr", "--align", "many"],
         "expected N, all or auto, not 'many'"),
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.exr", "--fold", "z"],
         "invalid choice"),
        # Once found by each view in its worker after Ray had started: exit 1 and the message once a view.
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "typo" / "v_%d.exr", "--channels",
          "depth,texcord"], "unknown channel 'texcord'"),
        # Trees carry positions only: the shading normal would have been the geometric one.
        ([atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "trees" / "v_%d.exr", "--channels",
          "depth,shading_normal", "--send", "trees"], "which a scene sent as trees does not carry"),
    ]
    for args, what in cases:
        r = subprocess.run([sys.executable, "-m", "rayfold.batch", *map(str, args)], capture_output=True, text=True,
                           timeout=120)
        assert r.returncode == 2 and what in r.stderr, (args, r.returncode, r.stderr)
    with open(tmp_path / "c.json", "w") as f:
        json.dump({"width": 8, "height": 8, "cameras": [{"eye": [0, 0, 1], "look_at": [0, 0, 0], "fov": 3}]}, f)
    r = batch_cli(atrium_path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "v_%d.exr")
    assert r.returncode == 2 and "cameras[0]: unknown key \"fov\"" in r.stderr, r.stderr
    assert os.listdir(tmp_path) == ["c.json"]
    with pytest.raises(rayfold.InputError, match="pass the scene's path instead of a Scene"):
        rayfold.batch.render(rayfold.Scene(atrium_path), tmp_path / "c.json", tmp_path / "v_%d.exr",
                             channels="texcoord", progress=False)
    with pytest.raises(rayfold.InputError, match="label_key is for a scene given by its path"):
        rayfold.batch.render(rayfold.Scene(atrium_path), tmp_path / "c.json", tmp_path / "v_%d.exr",
                             label_key="category", progress=False)
    assert os.listdir(tmp_path) == ["c.json"]


def test_labels_keep_their_table_in_the_zarr_store_and_the_exrs(bin_dir, tmp_path):
    zarr = pytest.importorskip("zarr", reason="zarr stores need zarr (tools/scripts/python-env.sh installs it)")
    path = tmp_path / "gbuffer.glb"
    subprocess.run([str(bin_dir / "rayfold-gen-scene"), "--gbuffer", "-o", str(path)], check=True,
                   capture_output=True)
    scene = rayfold.Scene(path, label_key="category")
    assert scene.labels == ["", "panel", "box"]
    cameras = [rayfold.Camera.look_at((0.4 * k - 0.4, 1.5, 4), (0, 0.3, 0), (0, 1, 0), 50, 40, 30) for k in range(3)]
    expected = scene.render_views(cameras, channels="label,instance_id")
    assert {1, 2} <= set(np.unique(expected[0].label)), "both labels in view"
    s = rayfold.batch.render(path, cameras, tmp_path / "v.zarr", channels="label,instance_id", label_key="category",
                             progress=False)
    assert (s.rendered, s.failed) == (3, [])
    g = zarr.open_group(str(tmp_path / "v.zarr"), mode="r")
    assert g.attrs["labels"] == scene.labels  # what the integers name; without it they named nothing
    for i, e in enumerate(expected):
        assert g["label"][i].tobytes() == e.label.tobytes(), f"view {i}"
    camera_list(tmp_path / "c.json", 2, 40, 30)
    r = batch_cli(path, "--cameras", tmp_path / "c.json", "-o", tmp_path / "e" / "v_%d.exr", "--channels", "label",
                  "--label-key", "category")
    assert r.returncode == 0, r.stderr
    header = rayfold.read_exr_header(tmp_path / "e" / "v_0.exr")
    assert header["labels"] == scene.labels, header


def test_the_cli_speaks_the_render_commands_words(atrium_path, tmp_path, cli):
    # --align all as rayfold render takes it, and a note about the camera file
    # as one "warning:" line, not a Python UserWarning with a source line;
    # output folders made as rayfold render makes them, and views named by
    # their file_path under %s as rayfold render names them.
    camera_list(tmp_path / "c.json", 2)
    with open(tmp_path / "c.json") as f:
        listed = json.load(f)
    frames = []
    for c in listed["cameras"]:
        eye, at = np.array(c["eye"], float), np.array(c["look_at"], float)
        z = eye - at
        z /= np.linalg.norm(z)
        x = np.cross([0.0, 1.0, 0.0], z)
        x /= np.linalg.norm(x)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, eye
        frames.append({"file_path": f"./train/r_{len(frames)}", "transform_matrix": m.tolist()})
    with open(tmp_path / "transforms.json", "w") as f:
        json.dump({"camera_angle_x": 0.8, "w": 32, "h": 24, "aabb_scale": 4, "frames": frames}, f)
    os.makedirs(tmp_path / "out")
    r = batch_cli(atrium_path, "--cameras", tmp_path / "transforms.json", "-o", tmp_path / "out" / "v_%d.exr",
                  "--align", "all", "-q")
    assert r.returncode == 0, r.stderr
    assert "2 of 2 views written" in r.stderr, r.stderr
    assert "warning: " in r.stderr and "ignored aabb_scale" in r.stderr, r.stderr
    assert "UserWarning" not in r.stderr and ".py:" not in r.stderr, r.stderr
    r = batch_cli(atrium_path, "--cameras", tmp_path / "transforms.json", "-o", tmp_path / "new" / "named" / "%s.exr",
                  "-q")
    assert r.returncode == 0, r.stderr
    # --fold auto and --align auto as rayfold render takes them: the cost
    # model's choice, the same bits.
    r = batch_cli(atrium_path, "--cameras", tmp_path / "transforms.json", "-o", tmp_path / "auto" / "v_%d.exr",
                  "--fold", "auto", "--align", "auto", "--kernel", "auto", "-q")
    assert r.returncode == 0, r.stderr
    subprocess.run([cli, "render", atrium_path, "-q", "--cameras", tmp_path / "transforms.json", "-o",
                    tmp_path / "render" / "%s.exr"], check=True)
    for i in range(2):
        got = rayfold.read_exr(tmp_path / "new" / "named" / f"r_{i}.exr")
        for want in (rayfold.read_exr(tmp_path / "out" / f"v_{i}.exr"),
                     rayfold.read_exr(tmp_path / "auto" / f"v_{i}.exr"),
                     rayfold.read_exr(tmp_path / "render" / f"r_{i}.exr")):
            for p in PLANES:
                assert got[p].tobytes() == want[p].tobytes(), f"view {i}, plane {p}"
    frames[1]["file_path"] = "./test/r_0.png"
    with open(tmp_path / "clash.json", "w") as f:
        json.dump({"camera_angle_x": 0.8, "w": 32, "h": 24, "frames": frames}, f)
    r = batch_cli(atrium_path, "--cameras", tmp_path / "clash.json", "-o", tmp_path / "clash" / "%s.exr", "-q")
    assert r.returncode == 2, r.stderr
    assert "views 0 ('./train/r_0') and 1 ('./test/r_0.png') would both write" in r.stderr, r.stderr


def test_memory_stays_flat_from_100_to_10000_views(atrium_path, tmp_path):
    peaks = {}
    for count in (100, 10000):
        d = tmp_path / str(count)
        os.makedirs(d)
        camera_list(d / "c.json", count)
        r = batch_cli(atrium_path, "--cameras", d / "c.json", "-o", d / "v_%05d.exr", "--workers", "2", "-q",
                      "--no-verify", "--summary", d / "s.json")
        assert r.returncode == 0, r.stderr
        s = summary(d / "s.json")
        assert s["written"] == count
        peaks[count] = (s["driver_peak_rss_mb"], s["worker_peak_rss_mb"])
    (d100, w100), (d10k, w10k) = peaks[100], peaks[10000]
    assert d10k <= 2 * d100 and w10k <= 2 * w100, f"peak RSS MB (driver, worker): 100 views {peaks[100]}, " \
                                                   f"10,000 views {peaks[10000]}"


def test_the_end_of_a_run_removes_what_ended_writers_left(tmp_path):
    """A rerun right after a stopped one found a killed worker's temporary
    still there (the worker was still exiting when the rerun's own scan ran);
    the end of a run removes those of writers that have ended, zombies
    among them, and keeps a live one's and a user's files."""
    from rayfold._batch_outputs import ExrOutput
    gone = subprocess.Popen(["/bin/true"])
    gone.wait()
    zombie = os.fork()
    if zombie == 0:
        os._exit(0)
    deadline = time.monotonic() + 5
    while time.monotonic() < deadline and ") Z" not in open(f"/proc/{zombie}/stat").read():
        time.sleep(0.005)
    names = [f".v_00001.exr.rayfold-{gone.pid}-0.tmp", f".v_00002.exr.rayfold-{zombie}-4.tmp",
             f".v_00003.exr.rayfold-{os.getpid()}-1.tmp", "notes.tmp", "v_00000.exr"]
    for n in names:
        (tmp_path / n).write_text("partial")
    ExrOutput(str(tmp_path / "v_%05d.exr"), 4).remove_all_partial()
    os.waitpid(zombie, 0)
    assert sorted(os.listdir(tmp_path)) == sorted(names[2:])
