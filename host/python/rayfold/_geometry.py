"""The scene's triangles in world space, for the other tools a user pairs
with rayfold (ray casters, point samplers, mesh exports) and for looking up
what a pixel hit."""
from collections import namedtuple

import numpy as np

WorldTriangles = namedtuple("WorldTriangles", ["triangles", "instance_id", "primitive_id", "first_row"])
WorldTriangles.__doc__ = """triangles: (T, 3, 3) float32, each vertex transformed in double by its
instance's world transform and rounded once. instance_id, primitive_id: (T,)
uint32, the ids a G-buffer reports for that triangle. first_row: (I + 1,)
int64, instance i's triangles are rows first_row[i] to first_row[i + 1], so a
hit (instance, primitive) is row first_row[instance] + primitive."""


def world_triangles(scene):
    """Every instance's triangles in world space at the scene's current pose
    (after set_transform and set_time), instance by instance in primitive
    order (WorldTriangles). An instance with a zero scale, which renders
    nothing, has its triangles collapsed to points."""
    parts, inst_ids, prim_ids = [], [], []
    first_row = np.zeros(scene.instance_count + 1, dtype=np.int64)
    meshes = {}
    for inst in range(scene.instance_count):
        mesh = scene.instance_mesh(inst)
        if mesh not in meshes:
            p = np.asarray(scene.mesh_positions(mesh), dtype=np.float64).reshape(-1, 3)
            idx = np.asarray(scene.mesh_triangles(mesh), dtype=np.int64).reshape(-1, 3)
            meshes[mesh] = (p, idx)
        p, idx = meshes[mesh]
        m = np.asarray(scene.transform(inst), dtype=np.float64)
        parts.append((p @ m[:3, :3].T + m[:3, 3])[idx].astype(np.float32))
        inst_ids.append(np.full(len(idx), inst, dtype=np.uint32))
        prim_ids.append(np.arange(len(idx), dtype=np.uint32))
        first_row[inst + 1] = first_row[inst] + len(idx)
    if not parts:
        empty = np.zeros(0, dtype=np.uint32)
        return WorldTriangles(np.zeros((0, 3, 3), np.float32), empty, empty, first_row)
    return WorldTriangles(np.concatenate(parts), np.concatenate(inst_ids), np.concatenate(prim_ids), first_row)
