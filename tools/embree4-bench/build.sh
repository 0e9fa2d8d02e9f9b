#!/usr/bin/env bash
# Builds embree4-bench, the Embree 4 side of `isir bench`, against Intel's Embree 4.4.0
# release library. That library (with the TBB it needs) ships inside one PyPI wheel,
# embreex==4.4.0.post1: this script downloads that one wheel with pip, pinned by its sha256,
# unpacks its two shared libraries with Python's zipfile, and compiles against the Embree
# 4.4.0 headers vendored in include/embree4 (the wheel has none; see NOTICE).
# Needs cc, and python3 with pip (or with venv, to make a throwaway pip). x86_64 Linux only.
#
# Usage: tools/embree4-bench/build.sh [OUTPUT]
#   OUTPUT defaults to ~/.cache/isir/embree4-bench ($XDG_CACHE_HOME/isir/...), where
#   `isir bench` looks for it; an existing directory (or a path ending in /) means
#   OUTPUT/embree4-bench. The script prints the path it built.
# The wheel and the libraries stay in ~/.cache/isir/embree4 (EMBREE4_CACHE overrides): the
# binary finds them by its rpath (absolute, also for a relative EMBREE4_CACHE), so it runs
# from anywhere as long as that folder stays.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
cache_root=${XDG_CACHE_HOME:-$HOME/.cache}/isir
out=${1:-$cache_root/embree4-bench}
if [ -d "$out" ] || [[ $out == */ ]]; then out=${out%/}/embree4-bench; fi
cache=${EMBREE4_CACHE:-$cache_root/embree4}

# The one file downloaded: the CPython 3.11 build (any of the wheel's builds bundles the
# same libraries, which do not depend on Python).
wheel=embreex-4.4.0.post1-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl
sha256=2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f

die() { echo "build.sh: $*" >&2; exit 1; }
[ "$(uname -s)-$(uname -m)" = Linux-x86_64 ] || die "the wheel's Embree 4 library is for x86_64 Linux only"
command -v cc >/dev/null || die "a C compiler (cc) is needed: apt-get install gcc"
command -v python3 >/dev/null || die "python3 is needed (to download and unpack the wheel)"
mkdir -p "$cache" "$(dirname "$out")"
# Absolute: the binary's rpath is this folder, whatever directory it later runs from.
cache=$(CDPATH= cd -- "$cache" && pwd)
lib=$cache/lib
tmpdir=$(mktemp -d "$cache/tmp.XXXXXX")
trap 'rm -rf "$tmpdir"' EXIT

# ---- The wheel, checked by its hash (again when it was already there: a cut download) ----
if [ -f "$cache/$wheel" ] && ! echo "$sha256  $cache/$wheel" | sha256sum -c --status; then
  echo "build.sh: $cache/$wheel does not match its sha256: downloading it again" >&2
  rm -f "$cache/$wheel"
fi
if [ ! -f "$cache/$wheel" ]; then
  if python3 -m pip --version >/dev/null 2>&1; then
    pip=(python3 -m pip)
  elif python3 -m venv "$tmpdir/venv" >/dev/null 2>&1; then
    pip=("$tmpdir/venv/bin/python" -m pip)
  else
    die "python3 has no pip and no venv: apt-get install python3-pip (or python3-venv)"
  fi
  echo "embreex==4.4.0.post1 --hash=sha256:$sha256" > "$tmpdir/requirements.txt"
  echo "build.sh: downloading $wheel (14 MB) from PyPI" >&2
  # --require-hashes: pip refuses any other file; --no-deps: this one wheel only.
  "${pip[@]}" download --quiet --disable-pip-version-check --no-deps --only-binary=:all: \
    --python-version 3.11 --implementation cp --abi cp311 --platform manylinux_2_28_x86_64 \
    --require-hashes -r "$tmpdir/requirements.txt" -d "$tmpdir/download" >&2
  mv "$tmpdir/download/$wheel" "$cache/$wheel"
fi

# ---- The two libraries, unpacked whole into lib/ (a temporary folder, then a rename) ----
if ! ls "$lib"/libembree4-*.so.4 >/dev/null 2>&1; then
  python3 - "$cache/$wheel" "$tmpdir/lib" <<'PY'
import os, re, sys, zipfile
wheel, dest = sys.argv[1], sys.argv[2]
os.makedirs(dest)
with zipfile.ZipFile(wheel) as z:
    names = [n for n in z.namelist() if re.fullmatch(r"embreex\.libs/lib[\w.-]+\.so(\.\d+)*", n)]
    if not any("libembree4" in n for n in names):
        sys.exit(f"build.sh: {wheel} holds no libembree4")
    for n in names:
        # Only the file's own name is used: nothing is written outside dest.
        path = os.path.join(dest, os.path.basename(n))
        with z.open(n) as src, open(path, "wb") as dst:
            while chunk := src.read(1 << 20):
                dst.write(chunk)
        os.chmod(path, 0o755)
PY
  rm -rf "$lib" && mv "$tmpdir/lib" "$lib"
fi
so=$(ls "$lib"/libembree4-*.so.4 | head -n 1)

# ---- The tool, built beside its target and renamed ----
bin=$(mktemp "$out.XXXXXX")
trap 'rm -rf "$tmpdir" "$bin"' EXIT
cc -std=c11 -O3 -march=native -fopenmp -Wall -Wextra -I"$here/include" -o "$bin" \
  "$here/embree4_bench.c" "$here/../common/bench_common.c" "$so" -Wl,-rpath,"$lib" -lm
chmod 755 "$bin"
# -T: never into a directory of that name under another name.
mv -fT "$bin" "$out"
echo "$out"
