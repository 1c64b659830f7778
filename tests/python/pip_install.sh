#!/usr/bin/env bash
# pip install . from the source tree into a fresh virtual environment, then
# renders through the installed module. usage: pip_install.sh SOURCE WORK
set -euo pipefail
source=$1 work=$2
rm -rf "$work" && mkdir -p "$work"
/usr/bin/python3 -m venv "$work/venv"
# A copy without build folders, as a clean checkout would be.
tar -C "$source" --exclude='./build*' --exclude=./.git --exclude=./out --exclude=./.gpu -cf - . | (mkdir -p "$work/src" && tar -C "$work/src" -xf -)
CMAKE_BUILD_PARALLEL_LEVEL=$(nproc) "$work/venv/bin/python" -m pip install -q "$work/src"
# The console script rayfold-batch comes with the package (Ray is the
# batch extra's; --help needs none).
"$work/venv/bin/rayfold-batch" --help >/dev/null
# The README's Python lines, as written, in the fresh environment.
"$work/venv/bin/python" "$source/tests/python/run_readme.py"
cd "$work"
"$work/venv/bin/python" - "$source/scenes/atrium.glb" <<'PY'
import sys

import numpy as np
import rayfold

scene = rayfold.Scene(sys.argv[1])
g = scene.render(scene.default_camera(64, 36), fold="xy")
ref = scene.render(scene.default_camera(64, 36), backend="cpu")
assert np.array_equal(g.depth.view(np.uint32), ref.depth.view(np.uint32))
assert g.hits > 0
print("rayfold", rayfold.__version__, "from", rayfold.__file__, ":", g.hits, "pixels hit")
PY
