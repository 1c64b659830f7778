"""Every resolved channel of the G-buffer's test scene (`rayfold-gen-scene --gbuffer`:
textures, a normal map, vertex colours, a mirrored instance, an animated node, a skinned
mesh, labels) against a float64 resolve of the same file made here (issue 49, part 5):
the file read by this test's own GLB and PNG readers, the node hierarchy posed at the
render's time with glTF's LINEAR interpolation (slerp for rotations), the skin blended
from its joints, and each channel computed from rayfold's hit (instance, triangle,
barycentrics) as glTF defines it. Flow is checked against the same surface point posed
at the other time and projected through the file's camera."""
import json
import pathlib
import struct
import subprocess
import zlib

import numpy as np
import pytest

import rayfold

SIZE = (320, 240)
FLOAT_TOL = 2e-6  # relative to the value's scale: a few float roundings of double sums
EVERY = ("position,object_position,shading_normal,texcoord,material_id,base_color,metallic_roughness,emissive,"
         "label,tangent,mapped_normal,instance_id,primitive_id,barycentrics,depth")


# ---- the file, read here -------------------------------------------------------------------------------------

def read_png(data):
    """An 8-bit RGBA, non-interlaced PNG's texels (H, W, 4), every row filter undone."""
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, header = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    w, h, depth, colour, _, _, interlace = header
    assert (depth, colour, interlace) == (8, 6, 0), header
    raw, bpp, stride = zlib.decompress(idat), 4, 4 * w
    out = np.zeros((h, stride), np.int64)
    for y in range(h):
        kind, line = raw[y * (stride + 1)], np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int64)
        prior = out[y - 1] if y else np.zeros(stride, np.int64)
        row = out[y]
        for x in range(stride):
            a = row[x - bpp] if x >= bpp else 0
            b, c = prior[x], prior[x - bpp] if x >= bpp else 0
            if kind == 0:
                predictor = 0
            elif kind == 1:
                predictor = a
            elif kind == 2:
                predictor = b
            elif kind == 3:
                predictor = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                predictor = a if pa <= pb and pa <= pc else b if pb <= pc else c
            row[x] = (line[x] + predictor) & 0xFF
    return out.reshape(h, w, 4)


class Glb:
    def __init__(self, path):
        data = pathlib.Path(path).read_bytes()
        magic, version, _ = struct.unpack("<4sII", data[:12])
        assert magic == b"glTF" and version == 2
        json_len = struct.unpack("<I", data[12:16])[0]
        self.j = json.loads(data[20:20 + json_len])
        self.bin = data[20 + json_len + 8:]

    def view(self, i):
        v = self.j["bufferViews"][i]
        return self.bin[v.get("byteOffset", 0):v.get("byteOffset", 0) + v["byteLength"]]

    def accessor(self, i):
        a = self.j["accessors"][i]
        dtype = {5126: np.float32, 5121: np.uint8, 5123: np.uint16, 5125: np.uint32}[a["componentType"]]
        n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[a["type"]]
        raw = self.view(a["bufferView"])[a.get("byteOffset", 0):]
        return np.frombuffer(raw, dtype, a["count"] * n).reshape(a["count"], n).astype(np.float64)

    def image(self, i):
        return read_png(self.view(self.j["images"][i]["bufferView"]))


def quat_matrix(q):
    x, y, z, w = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def slerp(a, b, s):
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    d = np.dot(a, b)
    if d < 0:
        b, d = -b, -d
    if d > 1 - 1e-12:
        return a + s * (b - a)
    angle = np.arccos(d)
    return (np.sin((1 - s) * angle) * a + np.sin(s * angle) * b) / np.sin(angle)


def local_matrices(f, t):
    """Each node's local matrix at time t (its TRS, the animation's LINEAR channels sampled)."""
    trs = [{"translation": np.array(n.get("translation", [0, 0, 0]), float),
            "rotation": np.array(n.get("rotation", [0, 0, 0, 1]), float),
            "scale": np.array(n.get("scale", [1, 1, 1]), float)} for n in f.j["nodes"]]
    for anim in f.j.get("animations", []):
        for ch in anim["channels"]:
            smp = anim["samplers"][ch["sampler"]]
            assert smp["interpolation"] == "LINEAR"
            times, values = f.accessor(smp["input"])[:, 0], f.accessor(smp["output"])
            k = int(np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2))
            s = float(np.clip((t - times[k]) / (times[k + 1] - times[k]), 0.0, 1.0))
            path = ch["target"]["path"]
            trs[ch["target"]["node"]][path] = (slerp(values[k], values[k + 1], s) if path == "rotation" else
                                               (1 - s) * values[k] + s * values[k + 1])
    out = []
    for n, p in zip(f.j["nodes"], trs):
        assert "matrix" not in n
        m = np.eye(4)
        m[:3, :3] = quat_matrix(p["rotation"]) * p["scale"]
        m[:3, 3] = p["translation"]
        out.append(m)
    return out


def world_matrices(f, t):
    local, world = local_matrices(f, t), {}

    def visit(i, parent):
        world[i] = parent @ local[i]
        for c in f.j["nodes"][i].get("children", []):
            visit(c, world[i])

    for root in f.j["scenes"][f.j.get("scene", 0)]["nodes"]:
        visit(root, np.eye(4))
    return world


def posed_instances(f, t):
    """Per mesh node (by name): its corners' float64 attributes in world space at time t and in the mesh's
    own (a skinned mesh's own space is the posed one, as rayfold keeps it)."""
    world = world_matrices(f, t)
    out = {}
    for i, node in enumerate(f.j["nodes"]):
        if "mesh" not in node:
            continue
        prim = f.j["meshes"][node["mesh"]]["primitives"][0]
        a = {k: f.accessor(v) for k, v in prim["attributes"].items()}
        p, n = a["POSITION"], a["NORMAL"]
        tangent = a.get("TANGENT")
        if "skin" in node:
            skin = f.j["skins"][node["skin"]]
            inverse_bind = f.accessor(skin["inverseBindMatrices"]).reshape(-1, 4, 4).transpose(0, 2, 1)
            joint = np.array([world[j] @ ib for j, ib in zip(skin["joints"], inverse_bind)])
            w, js = a["WEIGHTS_0"], a["JOINTS_0"].astype(int)
            m = np.einsum("vk,vkij->vij", w, joint[js]) / w.sum(1)[:, None, None]
            object_p = np.einsum("vij,vj->vi", m[:, :3, :3], p) + m[:, :3, 3]
            nm = np.einsum("vk,vkij->vij", w, np.linalg.inv(joint[js][..., :3, :3]).transpose(0, 1, 3, 2))
            object_n = np.einsum("vij,vj->vi", nm, n) / w.sum(1)[:, None]
            to_world = np.eye(4)
        else:
            object_p, object_n, to_world = p, n, world[i]
        linear = to_world[:3, :3]
        corners = {
            "object": object_p,
            "world": object_p @ linear.T + to_world[:3, 3],
            "normal": object_n @ np.linalg.inv(linear),  # through the inverse transpose
            "texcoord": a.get("TEXCOORD_0"),
            "color": a.get("COLOR_0"),
            "tangent": None if tangent is None else np.c_[tangent[:, :3] @ linear.T, tangent[:, 3]],
            "indices": f.accessor(prim["indices"])[:, 0].astype(int).reshape(-1, 3),
            "material": prim["material"],
            "handedness": np.sign(np.linalg.det(linear)),
            "extras": node.get("extras"),
        }
        out[node.get("name")] = corners
    return out


def srgb(c):
    c = c / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def texel(image, sampler, uv):
    """NEAREST at level 0 with the sampler's wrap modes: the texel holding uv * size."""
    h, w, _ = image.shape

    def wrap(i, n, mode):
        if mode == 33071:
            return np.clip(i, 0, n - 1)
        if mode == 33648:
            m = np.mod(i, 2 * n)
            return np.where(m < n, m, 2 * n - 1 - m)
        return np.mod(i, n)

    x = wrap(np.floor(uv[:, 0] * w).astype(int), w, sampler.get("wrapS", 10497))
    y = wrap(np.floor(uv[:, 1] * h).astype(int), h, sampler.get("wrapT", 10497))
    return image[y, x].astype(np.float64)


def away_from_texel_edges(uv, size):
    """Pixels whose texture coordinates are not within 1e-3 texel of an edge (NEAREST is a step there)."""
    frac = np.mod(uv * size, 1.0)
    return ((frac > 1e-3) & (frac < 1 - 1e-3)).all(axis=1)


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# ---- the test ------------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def scene_file(tmp_path_factory, bin_dir):
    path = tmp_path_factory.mktemp("gbuffer") / "gbuffer.glb"
    subprocess.run([str(bin_dir / "rayfold-gen-scene"), "--gbuffer", "-o", str(path)], check=True,
                   capture_output=True)
    return path


def expect_close(got, want, scale_tol, what):
    got, want = np.asarray(got, np.float64), np.asarray(want, np.float64)
    err = np.abs(got - want)
    bound = scale_tol * np.maximum(1.0, np.abs(want))
    bad = np.argwhere(err > bound)
    assert bad.size == 0, (f"{what}: {len(bad)} values out of tolerance; first at {bad[0].tolist()}: got "
                           f"{got[tuple(bad[0])]}, want {want[tuple(bad[0])]}")


@pytest.mark.parametrize("t", [0.0, 0.7, 2.0])
def test_every_channel_equals_a_float64_resolve_of_the_file(scene_file, t):
    f = Glb(scene_file)
    scene = rayfold.Scene(str(scene_file), label_key="category")
    camera = scene.default_camera(*SIZE)
    g = scene.render(camera, time=t, channels=EVERY)
    posed = posed_instances(f, t)
    names = scene.instance_names
    assert sorted(names) == sorted(posed), names
    images = [f.image(i) for i in range(len(f.j["images"]))]

    def sample(info, uv):
        """A textureInfo's texels at uv: its texture's image through its texture's sampler."""
        texture = f.j["textures"][info["index"]]
        return texel(images[texture["source"]], f.j["samplers"][texture["sampler"]], uv)

    hit = g.instance_id.ravel() != rayfold.MISS
    seen = set()
    for inst, name in enumerate(names):
        c = posed[name]
        sel = np.flatnonzero(g.instance_id.ravel() == inst)
        assert sel.size > 400, f"{name}: {sel.size} pixels: the scene's camera should see every instance well"
        seen.add(name)
        tri = g.primitive_id.ravel()[sel].astype(int)
        bary = g.barycentrics.reshape(-1, 2)[sel].astype(np.float64)
        u, v = bary[:, 0:1], bary[:, 1:2]
        b0 = 1.0 - u - v
        corner = c["indices"][tri]

        def interp(values):
            return b0 * values[corner[:, 0]] + u * values[corner[:, 1]] + v * values[corner[:, 2]]

        def plane(name_, n):
            return getattr(g, name_).reshape(-1, n)[sel]

        expect_close(plane("position", 3), interp(c["world"]), FLOAT_TOL, f"{name} position")
        expect_close(plane("object_position", 3), interp(c["object"]), FLOAT_TOL, f"{name} object_position")
        normal = unit(interp(c["normal"]))
        expect_close(plane("shading_normal", 3), normal, FLOAT_TOL, f"{name} shading_normal")
        material = f.j["materials"][c["material"]]
        assert (plane("material_id", 1) == c["material"]).all(), name
        label = (c["extras"] or {}).get("category", "")
        assert [scene.labels[i] for i in np.unique(plane("label", 1))] == [label], name
        pbr = material.get("pbrMetallicRoughness", {})
        factor = np.array(pbr.get("baseColorFactor", [1, 1, 1, 1]))
        colour = interp(c["color"]) if c["color"] is not None else np.ones((sel.size, 4))
        if c["texcoord"] is None:
            expect_close(plane("texcoord", 2), np.zeros((sel.size, 2)), 0, f"{name} texcoord (none: 0)")
            expect_close(plane("base_color", 4), factor * colour, FLOAT_TOL, f"{name} base_color")
            expect_close(plane("metallic_roughness", 2),
                         np.tile([pbr.get("metallicFactor", 1), pbr.get("roughnessFactor", 1)], (sel.size, 1)),
                         FLOAT_TOL, f"{name} metallic_roughness")
            expect_close(plane("mapped_normal", 3), normal, FLOAT_TOL, f"{name} mapped_normal (no normal map)")
            continue
        uv = interp(c["texcoord"])
        expect_close(plane("texcoord", 2), uv, FLOAT_TOL, f"{name} texcoord")
        ok = away_from_texel_edges(uv, 8)
        assert ok.mean() > 0.9, name
        base = sample(pbr["baseColorTexture"], uv)
        base_linear = np.c_[srgb(base[:, :3]), base[:, 3] / 255.0]
        expect_close(plane("base_color", 4)[ok], (factor * colour * base_linear)[ok], FLOAT_TOL, f"{name} base_color")
        mr = sample(pbr["metallicRoughnessTexture"], uv) / 255.0
        want_mr = np.c_[pbr["metallicFactor"] * mr[:, 2], pbr["roughnessFactor"] * mr[:, 1]]
        expect_close(plane("metallic_roughness", 2)[ok], want_mr[ok], FLOAT_TOL, f"{name} metallic_roughness")
        emissive = np.array(material["emissiveFactor"]) * srgb(sample(material["emissiveTexture"], uv)[:, :3])
        expect_close(plane("emissive", 3)[ok], emissive[ok], FLOAT_TOL, f"{name} emissive")
        # The tangent frame: the file's TANGENT through the node's linear part, made orthogonal to the
        # shading normal; its sign times the transform's handedness.
        tw = interp(c["tangent"])
        tangent = unit(tw[:, :3] - normal * np.sum(normal * tw[:, :3], axis=1, keepdims=True))
        sign = np.where(tw[:, 3] < 0, -1.0, 1.0) * c["handedness"]
        expect_close(plane("tangent", 4), np.c_[tangent, sign], FLOAT_TOL, f"{name} tangent")
        scale = material["normalTexture"].get("scale", 1.0)
        s = 2.0 * sample(material["normalTexture"], uv)[:, :3] / 255.0 - 1.0
        bitangent = sign[:, None] * np.cross(normal, tangent)
        mapped = unit(tangent * (s[:, 0:1] * scale) + bitangent * (s[:, 1:2] * scale) + normal * s[:, 2:3])
        expect_close(plane("mapped_normal", 3)[ok], mapped[ok], 4 * FLOAT_TOL, f"{name} mapped_normal")
    assert seen == set(posed)
    assert (~hit).sum() > 1000, "the background should show"


def test_flow_follows_the_animated_node_and_the_skin(scene_file):
    """From t = 0.4 to t = 1.6: each hit's surface point, posed again at 1.6 on the same triangle with the
    same barycentrics, projected through the file's camera (no rotation, yfov 0.9, at its translation)."""
    f = Glb(scene_file)
    scene = rayfold.Scene(str(scene_file))
    camera = scene.default_camera(*SIZE)
    g = scene.render(camera, time=0.4, channels="instance_id,primitive_id,barycentrics,flow",
                     flow_to=(camera, 1.6))
    later = posed_instances(f, 1.6)
    cam_node = next(n for n in f.j["nodes"] if "camera" in n)
    eye = np.array(cam_node["translation"], float)
    w, h = SIZE
    focal = 0.5 * h / np.tan(0.5 * f.j["cameras"][0]["perspective"]["yfov"])
    moving = 0
    for inst, name in enumerate(scene.instance_names):
        sel = np.flatnonzero(g.instance_id.ravel() == inst)
        tri = g.primitive_id.ravel()[sel].astype(int)
        bary = g.barycentrics.reshape(-1, 2)[sel].astype(np.float64)
        u, v = bary[:, 0:1], bary[:, 1:2]
        corner = later[name]["indices"][tri]
        world = later[name]["world"]
        p = (1.0 - u - v) * world[corner[:, 0]] + u * world[corner[:, 1]] + v * world[corner[:, 2]] - eye
        target = np.c_[0.5 * w + focal * p[:, 0] / -p[:, 2], 0.5 * h - focal * p[:, 1] / -p[:, 2]]
        centre = np.c_[sel % w + 0.5, sel // w + 0.5]
        want = target - centre
        got = g.flow.reshape(-1, 2)[sel]
        expect_close(got, want, 1e-4, f"{name} flow")
        moving += int((np.abs(want).max(axis=1) > 1.0).sum())
    assert moving > 500, "the box and the strip's upper half move between the two times"


def test_attributes_first_read_in_a_posed_render_stay_read(scene_file):
    """A render at another time that is the first to read normals and labels keeps them for the scene put
    back (a bug: the scene was put back as it was before the render, without them, so later renders shaded
    flat and the labels' table read [''])."""
    scene, fresh = rayfold.Scene(str(scene_file), label_key="category"), rayfold.Scene(str(scene_file),
                                                                                        label_key="category")
    camera = scene.default_camera(*SIZE)
    scene.render(camera, time=0.7, channels="shading_normal,label")
    assert scene.labels == ["", "panel", "box"]
    g, want = (s.render(camera, channels="shading_normal,label") for s in (scene, fresh))
    assert g.shading_normal.tobytes() == want.shading_normal.tobytes()
    assert g.label.tobytes() == want.label.tobytes()


def test_a_users_slips_are_named(scene_file, tmp_path):
    """What a new user tried: a NaN time (None is the scene's own pose), a label key no node has (a typo),
    an EXR written under another extension. Each is named, nothing half-done."""
    scene = rayfold.Scene(str(scene_file), label_key="categroy")
    camera = scene.default_camera(*SIZE)
    with pytest.raises(rayfold.InputError, match="time must be a finite number"):
        scene.render(camera, channels="depth", time=float("nan"))
    with pytest.raises(rayfold.InputError, match="flow_to's time must be a finite number"):
        scene.render(camera, channels="flow", flow_to=(camera, float("nan")))
    with pytest.raises(rayfold.InputError, match=r"flow_to is \(time, Camera\); give it as \(Camera, time\)"):
        scene.render(camera, channels="flow", flow_to=(0.5, camera))
    g = scene.render(camera, channels="label")
    assert any("no node's extras has the label key 'categroy'" in w for w in g.warnings), g.warnings
    assert set(np.unique(g.label)) <= {0, rayfold.MISS}
    with pytest.raises(rayfold.InputError, match="name the file .exr"):
        g.write_exr(str(tmp_path / "g.png"), scene)
    assert not (tmp_path / "g.png").exists()


def test_a_frame_says_its_time(scene_file, tmp_path):
    """GBuffer.time is the pose a render shows, and the EXR keeps it (rayfold:time): a frame of an animation
    can be dated from its file. The rest pose has none."""
    scene = rayfold.Scene(str(scene_file))
    camera = scene.default_camera(*SIZE)
    g = scene.render(camera, channels="depth", time=0.7)
    assert g.time == 0.7
    g.write_exr(str(tmp_path / "t.exr"), scene)
    assert rayfold.read_exr_header(str(tmp_path / "t.exr"))["time"] == 0.7
    rest = scene.render(camera, channels="depth")
    assert rest.time is None
    rest.write_exr(str(tmp_path / "rest.exr"), scene)
    assert rayfold.read_exr_header(str(tmp_path / "rest.exr"))["time"] is None
    scene.set_time(1.25)
    assert scene.render(camera, channels="depth").time == 1.25
