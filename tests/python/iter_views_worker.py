"""Renders N views of the atrium at 64x48 through Scene.iter_views from a
generator and prints, as JSON, the resident set after the first 100 views and
the peak at the end (tests/python/test_rayfold.py: memory stays flat)."""
import json
import resource
import sys

import rayfold


def resident_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize()


def peak_resident_bytes():
    """VmHWM: this process image's high-water mark. (ru_maxrss would carry
    the forking parent's peak across exec.)"""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmHWM in /proc/self/status")


def main():
    path, n = sys.argv[1], int(sys.argv[2])
    scene = rayfold.Scene(path)
    base = scene.default_camera(64, 48)
    eye = base.eye

    def cameras():
        for k in range(n):
            yield rayfold.Camera.look_at((eye[0] + 1e-3 * (k % 97), eye[1], eye[2]), (0, 2, 0), (0, 1, 0), 50.0, 64,
                                         48)

    after_100 = None
    hits = 0
    for k, g in enumerate(scene.iter_views(cameras(), fold="xy")):
        hits += g.hits
        if k == 99:
            after_100 = resident_bytes()
    peak = peak_resident_bytes()
    print(json.dumps({"views": k + 1, "after_100": after_100, "peak": peak, "hits": hits}))


if __name__ == "__main__":
    main()
