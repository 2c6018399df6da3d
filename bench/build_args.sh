# Sourced by bench/build_peer.sh and bench/build_plasp.sh after `set -euo pipefail`:
#
#   . "$(dirname "$0")/build_args.sh" "$@"
#
# checks their two arguments, SOURCE and PREFIX, and sets here (this folder), src and prefix
# (absolute); a PREFIX inside this repository is refused: what they build is no part of cplus.
if [ $# -ne 2 ]; then
    echo "usage: $0 SOURCE PREFIX" >&2
    exit 2
fi
here="$(cd "$(dirname "$0")" && pwd)"
src="$(cd "$1" && pwd)"
prefix="$(realpath -m "$2")"
case "$prefix/" in "$(cd "$here/.." && pwd)/"*) echo "$0: install it outside this repository" >&2; exit 2;; esac
