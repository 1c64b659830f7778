#!/bin/sh
# Runs each (test binary, test name) pair given in a private TMPDIR and
# fails unless every one ran and passed (a filter matching nothing, or a
# skip, would check nothing) and the TMPDIR is empty after them all.
d=$(mktemp -d) || exit 1
trap 'rm -rf "$d"' EXIT
while [ $# -ge 2 ]; do
  out=$(TMPDIR="$d" "$1" --gtest_filter="$2" 2>&1)
  case "$out" in
    *"[  PASSED  ] 1 test."*) ;;
    *) echo "$2 did not run and pass alone:"; echo "$out" | tail -20; exit 1 ;;
  esac
  shift 2
done
left=$(ls -A "$d")
if [ -n "$left" ]; then
  echo "left in TMPDIR: $left"
  exit 1
fi
