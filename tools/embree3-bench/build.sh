#!/usr/bin/env bash
# Builds embree3-bench, the Embree 3 side of `isir bench`, against Debian's Embree 3
# (package libembree-dev, 3.13). When the headers are missing it installs that package if
# it runs as root with apt-get, and otherwise says what to install.
#
# Usage: tools/embree3-bench/build.sh [OUTPUT]
#   OUTPUT defaults to ~/.cache/isir/embree3-bench ($XDG_CACHE_HOME/isir/...), where
#   `isir bench` looks for it; an existing directory (or a path ending in /) means
#   OUTPUT/embree3-bench. The script prints the path it built.
# Another Embree 3 install: EMBREE3_CFLAGS="-I.../include" EMBREE3_LIBS="-L.../lib -lembree3".
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
out=${1:-${XDG_CACHE_HOME:-$HOME/.cache}/isir/embree3-bench}
if [ -d "$out" ] || [[ $out == */ ]]; then out=${out%/}/embree3-bench; fi
cflags=${EMBREE3_CFLAGS:-}
libs=${EMBREE3_LIBS:--lembree3}

if [ -z "$cflags" ] && [ ! -e /usr/include/embree3/rtcore.h ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "build.sh: installing libembree-dev (Embree 3)" >&2
    apt-get update -qq >&2 && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq libembree-dev >&2
  else
    echo "build.sh: Embree 3 is not installed: run 'sudo apt-get install libembree-dev' (Debian, Ubuntu)," >&2
    echo "          or set EMBREE3_CFLAGS and EMBREE3_LIBS for another install" >&2
    exit 1
  fi
fi
command -v cc >/dev/null || { echo "build.sh: a C compiler (cc) is needed: apt-get install gcc" >&2; exit 1; }

mkdir -p "$(dirname "$out")"
# Built beside the target and renamed: a failed build never leaves half a binary there.
tmp=$(mktemp "$out.XXXXXX")
trap 'rm -f "$tmp"' EXIT
# shellcheck disable=SC2086 # the flags are word lists
cc -std=c11 -O3 -march=native -fopenmp -Wall -Wextra $cflags -o "$tmp" \
  "$here/embree3_bench.c" "$here/../common/bench_common.c" $libs -lm
chmod 755 "$tmp"
# -T: never into a directory of that name under another name.
mv -fT "$tmp" "$out"
echo "$out"
