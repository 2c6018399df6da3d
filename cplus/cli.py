"""The `cplus` command line (sub-commands are filled in as the packages land)."""
from __future__ import annotations

import sys


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "brick":
        from nxt_link.cli import brick_main

        return brick_main(argv[1:])
    if argv and argv[0] == "execute":
        from cplus.execute import execute_main

        return execute_main(argv[1:])
    print("usage: cplus {plan,ground,brick,execute} ...", file=sys.stderr)
    return 2


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
