"""Answers N rays of the atrium through Scene.intersect and prints, as JSON,
the peak resident set and the bytes of the arrays in and out
(tests/python/test_rayfold.py: a query's own memory does not grow with N)."""
import json
import sys

import numpy as np

import rayfold
from iter_views_worker import peak_resident_bytes


def main():
    path, n = sys.argv[1], int(sys.argv[2])
    scene = rayfold.Scene(path)
    lo, hi = np.asarray(scene.bounds[:3]), np.asarray(scene.bounds[3:])
    o = np.empty((n, 3), dtype=np.float32)  # filled in place: no float64 temporaries
    d = np.empty((n, 3), dtype=np.float32)
    o[:] = (lo + hi) / 2
    d[:, 0] = np.float32(0.25)
    d[:, 1] = np.float32(-1.0)
    d[:, 2] = np.linspace(-1, 1, n, dtype=np.float32)  # a fan from the centre down to the floor
    h = scene.intersect(o, d)
    arrays = o.nbytes + d.nbytes + sum(a.nbytes for a in h.values())
    print(json.dumps({"rays": n, "hits": int((h["instance_id"] != rayfold.MISS).sum()), "arrays": arrays,
                      "peak": peak_resident_bytes()}))


if __name__ == "__main__":
    main()
