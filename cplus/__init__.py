"""C+ planning in the style of CCALC (package root; the public API is filled in by cplus.api)."""
