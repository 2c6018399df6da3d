#!/usr/bin/env bash
# Build the peer that bench/bench_peer.py and bench/bench_planner.py compare with: Cplus2ASP 4
# (https://github.com/azreasoners/Cplus2ASP, GPL-3; no part of cplus) with PyPI's clingo 5.
#
#   bench/build_peer.sh SOURCE PREFIX
#
# SOURCE: a copy of the Cplus2ASP repository (its externals/ included); PREFIX: where to install
# (outside this repository). Needs: autoconf automake libtool make g++ libboost-all-dev flex
# bison re2c (Debian's names) and python3 with venv. Afterwards PREFIX/bin holds cplus2asp4,
# its tools, f2lp, and `clingo`: bench/peer_clingo.py run by PREFIX/venv's interpreter.
set -euo pipefail
. "$(dirname "$0")/build_args.sh" "$@"   # sets here, src, prefix
mkdir -p "$prefix"

# the upstream README's steps: its boost macro wants the installed Boost's version
boost_cv_lib_version="$(dpkg -s libboost-dev 2>/dev/null | sed -n 's/^Version: \([0-9]*\)\.\([0-9]*\).*/\1_\2/p')"
export boost_cv_lib_version
cd "$src"
./bootstrap.sh --prefix="$prefix"
make -j"$(nproc)"
make install
gcc -O2 -w externals/f2lp/f2lp.c -o "$prefix/bin/f2lp"

# clingo 5 from PyPI in an environment of its own, behind the `clingo` command the tool chain calls
python3 -m venv "$prefix/venv"
"$prefix/venv/bin/pip" install -q clingo
{ echo "#!$prefix/venv/bin/python"; tail -n +2 "$here/peer_clingo.py"; } > "$prefix/bin/clingo"
chmod +x "$prefix/bin/clingo"
echo "peer installed: $prefix/bin/cplus2asp4 (python bench/bench_peer.py --peer-bin $prefix/bin/cplus2asp4)"
