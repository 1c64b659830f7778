"""Mitsuba 3's side of tests/python/test_mitsuba_peer.py, in a process of its
own (Dr.Jit's LLVM backend and thread pool stay out of the test process, whose
other tests fork): reads IN.npz (world-space meshes, rays, the texture's file),
intersects every ray and writes OUT.npz with each hit's validity, triangle,
position, shading frame, dp/du, dp/dv, uv and the diffuse reflectance of a
bitmap texture reading that file with nearest filtering.
usage: mitsuba_worker.py IN.npz OUT.npz"""
import sys

import mitsuba as mi
import numpy as np


def main():
    mi.set_variant("llvm_ad_rgb")
    given = np.load(sys.argv[1])
    shapes = {"type": "scene"}
    for k in range(int(given["instances"])):
        p, n, t, tris = given[f"p{k}"], given[f"n{k}"], given["t"], given["tris"]
        mesh = mi.Mesh(f"instance{k}", len(p), len(tris), has_vertex_normals=True, has_vertex_texcoords=True)
        params = mi.traverse(mesh)
        params["vertex_positions"] = p.ravel()
        params["vertex_normals"] = n.ravel()
        params["vertex_texcoords"] = t.ravel()
        params["faces"] = tris.ravel()
        params.update()
        shapes[f"instance{k}"] = mesh
    scene = mi.load_dict(shapes)
    bsdf = mi.load_dict({"type": "diffuse", "reflectance": {"type": "bitmap", "filename": str(given["texture"]),
                                                            "filter_type": "nearest"}})
    o, d = given["origins"], given["directions"]
    si = scene.ray_intersect(mi.Ray3f(mi.Point3f(*o.T), mi.Vector3f(*d.T)))
    np.savez(sys.argv[2], valid=np.array(si.is_valid()), prim=np.array(si.prim_index), p=np.array(si.p).T,
             n=np.array(si.sh_frame.n).T, s=np.array(si.sh_frame.s).T, dp_dv=np.array(si.dp_dv).T,
             uv=np.array(si.uv).T, reflectance=np.array(bsdf.eval_diffuse_reflectance(si)).T)


if __name__ == "__main__":
    main()
