#!/usr/bin/env bash
# Installs rayfold's build and run dependencies from Debian packages.
# Shared by `make demo`, `make test` and .ci/run so that a fresh machine needs
# nothing but this repository. Does nothing when everything is present.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  pocl-opencl-icd ocl-icd-opencl-dev opencl-clhpp-headers
  libglm-dev libtinygltf-dev nlohmann-json3-dev libstb-dev
  libopenexr-dev googletest libgtest-dev
  libembree-dev
  python3-venv python3-dev
  libmeshoptimizer-dev libdraco-dev gltfpack draco
)
# Extra packages some targets ask for (for example the benchmark's peers).
if [ "$#" -gt 0 ]; then packages+=("$@"); fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
[ "${#missing[@]}" -eq 0 ] && exit 0

echo "install-deps: installing ${missing[*]}"
sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
