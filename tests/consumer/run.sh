#!/usr/bin/env bash
# Builds the consumer project against rayfold one way and runs it.
# usage: run.sh MODE SOURCE_DIR BUILD_DIR WORK_DIR
#   MODE package: installs BUILD_DIR into WORK_DIR/prefix first, and also runs
#   the installed CLI on its installed default scene.
set -euo pipefail
mode=$1 source=$2 build=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
args=(-DRAYFOLD_USE="$mode" -DCMAKE_BUILD_TYPE=Release)
case "$mode" in
  package)
    cmake --install "$build" --prefix "$work/prefix" >/dev/null
    args+=(-DCMAKE_PREFIX_PATH="$work/prefix")
    "$work/prefix/bin/rayfold" --version
    "$work/prefix/bin/rayfold" render --size 64x36 --fold xy --compare -o "$work/cli.exr" >/dev/null
    test -s "$work/cli.exr"
    ;;
  subdirectory) args+=(-DRAYFOLD_SOURCE="$source") ;;
  fetchcontent)
    # A release tarball of the working tree, as FetchContent would download it.
    tar -C "$source" --exclude='./build*' --exclude=./.git --exclude=./out -czf "$work/rayfold.tar.gz" .
    args+=(-DRAYFOLD_SOURCE="$work/rayfold.tar.gz")
    ;;
esac
cmake -S "$source/tests/consumer" -B "$work/build" "${args[@]}" >/dev/null
cmake --build "$work/build" -j "$(nproc)" >/dev/null
"$work/build/consumer" "$source/scenes/atrium.glb"
