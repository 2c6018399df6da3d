#!/usr/bin/env bash
# Build plasp + clingo, the ASP planner bench/bench_ipc.py compares with (planners plasp-seq and
# plasp-par): plasp 3 (https://github.com/potassco/plasp, MIT; no part of cplus) translates PDDL
# to ASP facts, its encodings/strips/ plan with clingo 5 (PyPI's clingo) in incremental mode.
#
#   bench/build_plasp.sh SOURCE PREFIX
#
# SOURCE: a copy of the plasp repository with its submodules lib/catch, lib/cxxopts, lib/variant
# (`git clone --recursive`); PREFIX: where to install (outside this repository). Needs: cmake,
# g++ (C++17), python3 with venv. Afterwards PREFIX/bin/plasp, PREFIX/encodings (plasp's own)
# and PREFIX/venv, whose interpreter has the clingo module; pass --plasp PREFIX to the bench
# or set CPLUS_PLASP=PREFIX.
set -euo pipefail
. "$(dirname "$0")/build_args.sh" "$@"   # sets here, src, prefix
for sub in lib/cxxopts/include lib/variant/include; do
    [ -d "$src/$sub" ] || { echo "$0: $src/$sub is missing: fetch plasp's submodules (git submodule update --init)" >&2; exit 2; }
done
mkdir -p "$prefix/bin"

# plasp 3.1.1 builds with -Werror, which GCC 12's new warnings (maybe-uninitialized in
# mapbox::variant) break, and its pinned cxxopts forgets <limits>: both fixed from the outside
build="$src/build/release"
mkdir -p "$build"
cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=Release "-DCMAKE_CXX_FLAGS=-Wno-error -include limits"
cmake --build "$build" -j"$(nproc)" --target plasp-app
install -m 755 "$build/bin/plasp" "$prefix/bin/plasp"
rm -rf "$prefix/encodings"
cp -r "$src/encodings" "$prefix/encodings"

# clingo 5 from PyPI in an environment of its own (the bench runs clingo's main loop through it)
python3 -m venv "$prefix/venv"
"$prefix/venv/bin/pip" install -q clingo
echo "plasp installed: $prefix/bin/plasp (python bench/bench_ipc.py --plasp $prefix ...)"
