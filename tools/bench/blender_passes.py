"""Blender's Cycles render passes on a camera list, the dataset loop's Blender peer
(bench_dataset_loop.py runs it): inside Blender,

  blender -b --factory-startup --python blender_passes.py -- SCENE VIEWS.json WxH OUT_DIR REPS

imports the glTF with Blender's own importer, renders each view REPS times (the first a
warm-up) with Cycles on the CPU at 1 sample, no bounces, no denoising, persistent data
(the scene's BVH kept between views, as a dataset loop would), with the passes the
rayfold row writes (Z, Normal, Position, UV, IndexOB), and writes each view's passes as
one multilayer EXR, OUT_DIR/blender_I.exr. The pixel filter is 0.01 pixels wide, so the
one sample is taken at the pixel's centre, where rayfold's ray goes. OUT_DIR/blender.json
gets each view's render and write times in ms and the import's time in s.

Blender's world is glTF's turned Z-up (its importer maps glTF (x, y, z) to (x, -z, y)):
the views are given in glTF's frame and turned here; the Position pass is in Blender's.
"""
import json
import math
import os
import sys
import time

import bpy
import mathutils
import numpy

# Debian 12's Blender 3.4 importer uses numpy.bool, which its numpy 1.24 no
# longer has (removed after its deprecation in 1.20): the builtin it stood for.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

# Blender's frame from glTF's: (x, y, z) -> (x, -z, y).
BLENDER_FROM_GLTF = mathutils.Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))


def camera_to_world(view):
    """rayfold-peers' look-at view as a camera-to-world matrix in glTF's frame (-z forward, +y up)."""
    eye, target, up = (mathutils.Vector(view[k]) for k in ("eye", "look_at", "up"))
    back = (eye - target).normalized()
    right = up.cross(back).normalized()
    true_up = back.cross(right)
    m = mathutils.Matrix.Identity(4)
    for row in range(3):
        m[row][0], m[row][1], m[row][2], m[row][3] = right[row], true_up[row], back[row], eye[row]
    return m


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    scene_path, views_path, size, out_dir, reps = argv[0], argv[1], argv[2], argv[3], int(argv[4])
    width, height = (int(v) for v in size.split("x"))
    with open(views_path) as f:
        views = json.load(f)

    bpy.ops.wm.read_factory_settings(use_empty=True)
    t0 = time.perf_counter()
    bpy.ops.import_scene.gltf(filepath=scene_path)
    import_s = time.perf_counter() - t0
    scene = bpy.context.scene
    meshes = [o for o in scene.objects if o.type == "MESH"]
    for i, o in enumerate(meshes):
        o.pass_index = i + 1  # IndexOB: 0 is the background

    camera_data = bpy.data.cameras.new("view")
    camera = bpy.data.objects.new("view", camera_data)
    scene.collection.objects.link(camera)
    scene.camera = camera
    camera_data.sensor_fit = "VERTICAL"
    camera_data.clip_start = 1e-3
    camera_data.clip_end = 1e6

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 0
    scene.cycles.filter_width = 0.01
    scene.render.use_persistent_data = True
    scene.render.use_motion_blur = False
    scene.render.resolution_x, scene.render.resolution_y = width, height
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR_MULTILAYER"
    scene.render.image_settings.color_depth = "32"
    scene.render.image_settings.exr_codec = "ZIP"
    layer = scene.view_layers[0]
    layer.use_pass_z = True
    layer.use_pass_normal = True
    layer.use_pass_position = True
    layer.use_pass_uv = True
    layer.use_pass_object_index = True

    rows = []
    for i, view in enumerate(views):
        camera.matrix_world = BLENDER_FROM_GLTF @ camera_to_world(view)
        camera_data.angle_y = math.radians(view["vfov"])
        path = os.path.join(out_dir, f"blender_{i}.exr")
        render_ms, write_ms = [], []
        for _ in range(reps):
            t = time.perf_counter()
            bpy.ops.render.render(write_still=False)
            w = time.perf_counter()
            bpy.data.images["Render Result"].save_render(filepath=path)
            render_ms.append(1e3 * (w - t))
            write_ms.append(1e3 * (time.perf_counter() - w))
        rows.append({"view": i, "render_ms": render_ms, "write_ms": write_ms})
    with open(os.path.join(out_dir, "blender.json"), "w") as f:
        json.dump({"blender": bpy.app.version_string, "import_s": import_s, "meshes": len(meshes), "views": rows}, f)


main()
