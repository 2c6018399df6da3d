"""The obstacles of a scene, indexed once, and the fast `collision` external built on them.

The grounder evaluates ``collision(X1,Y1,X2,Y2)`` for every pair of grid points a law
mentions (tens of thousands of calls, the payload domain's grounding spends more time in them
than anywhere else), so the answer for integer points inside the grid comes from a table
computed in one vectorised shapely call the first time it is needed, and a call is two dict
lookups and an index into a row of bytes (well under a microsecond); any other argument goes
through an STRtree query and an LRU cache.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt
import shapely
from shapely.geometry import Polygon

from .geometry import Point2, segment_geometry

__all__ = ["Workspace"]

_log = logging.getLogger(__name__)

_MAX_TABLE_CELLS = 4_000_000
"""Above this many point pairs the table would cost more than it saves; use the cache."""


class Workspace:
    """Obstacles as an STRtree plus a prepared union; answers segment-versus-obstacle queries.

    Immutable after construction except for its caches, which never change an answer.

    >>> from shapely.geometry import box
    >>> ws = Workspace([box(2, 0, 3, 1)], grid=(0, 5, 0, 5))
    >>> ws.collision(0, 0, 5, 0), ws.collision(0, 2, 5, 2)    # grid points: from the table
    (True, False)
    >>> ws.collision(2.5, 0.5, 2.5, 0.5), ws.collision(0.5, 1.5, 3.5, 1.01)   # others: exact
    (True, False)
    >>> ws.hits(box(2.5, 0.5, 4, 4)), ws.hits(box(4, 4, 5, 5))
    ([0], [])
    """

    def __init__(self, polygons: Sequence[Polygon], grid: tuple[int, int, int, int]) -> None:
        self.polygons: tuple[Polygon, ...] = tuple(polygons)
        self.tree = shapely.STRtree(list(self.polygons))
        self.union = shapely.union_all(list(self.polygons)) if self.polygons else shapely.Polygon()
        shapely.prepare(self.union)
        self.grid = grid  # x_min, x_max, y_min, y_max
        self._table: npt.NDArray[np.bool_] | None = None
        self._tabulate = True
        self._cached = functools.lru_cache(maxsize=1 << 16)(self._segment_hits)
        self._index: dict[tuple[float, float], int] | None = None   # grid point -> row of the table
        self._rows: list[bytes] = []                                  # the table, one bytes per row
        self._shrunk: dict[float, tuple[Polygon, ...]] = {}
        self._boxes: list[tuple[int, tuple[float, float, float, float]]] = []
        if self.polygons:
            everything = shapely.box(*shapely.total_bounds(self.polygons))
            self._boxes = [(int(k), self.polygons[k].bounds) for k in self.tree.query(everything)]

    # -- queries ---------------------------------------------------------------------------
    def hits(self, geometry: shapely.Geometry) -> list[int]:
        """Indices of the obstacles that meet ``geometry`` (interior or boundary)."""
        return [int(i) for i in self.tree.query(geometry, predicate="intersects")]

    def shrunk(self, margin: float) -> tuple[Polygon, ...]:
        """Every obstacle shrunk by ``margin`` (mitred corners), as prepared polygons (an
        obstacle thinner than twice the margin has none; one that falls apart has several).
        Computed once per margin."""
        found = self._shrunk.get(margin)
        if found is None:
            found = self._shrunk[margin] = tuple(
                part for polygon in self.polygons
                for part in _parts(polygon.buffer(-margin, join_style="mitre")))
            for part in found:
                shapely.prepare(part)
        return found

    def candidates(self, points: Sequence[Point2]) -> list[int]:
        """Indices of obstacles whose bounding boxes meet the bounding box of ``points``, in
        the order the STRtree gives them (a tree query returns its hits in the order of a
        query for everything; the checker breaks ties between obstacles by this order).

        Compared box by box in Python: with a scene's few obstacles that is several times
        faster than building a query geometry for the tree, and the checker asks per motion."""
        xs = [p[0] for p in points]
        ys = [p[1] for p in points]
        x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
        return [k for k, (a0, b0, a1, b1) in self._boxes if a0 <= x1 and a1 >= x0 and b0 <= y1 and b1 >= y0]

    def _segment_hits(self, x1: float, y1: float, x2: float, y2: float) -> bool:
        return bool(self.union.intersects(segment_geometry((x1, y1), (x2, y2))))

    def collision(self, x1: float, y1: float, x2: float, y2: float) -> bool:
        """True when the closed segment (x1,y1)-(x2,y2) meets an obstacle (a point if equal).

        Grid points are looked up by value (``2``, ``2.0`` and ``True`` for 1 are the same
        key, and the table's answer for them is the geometric one, which the tests check)."""
        index = self._index if self._index is not None else self._build_index()
        i = index.get((x1, y1))
        if i is not None:
            j = index.get((x2, y2))
            if j is not None:
                return self._rows[i][j] == 1
        return self._cached(float(x1), float(y1), float(x2), float(y2))

    # -- the grid table --------------------------------------------------------------------
    def _build_index(self) -> dict[tuple[float, float], int]:
        """The grid points' rows in the table, and the table as bytes (empty when the grid is
        too large to tabulate: every call then goes through the cache)."""
        table = self._table if self._table is not None else self._build_table()
        index: dict[tuple[float, float], int] = {}
        if table is not None:
            x_min, x_max, y_min, y_max = self.grid
            index = {(x, y): k for k, (x, y) in enumerate((x, y) for x in range(x_min, x_max + 1)
                                                          for y in range(y_min, y_max + 1))}
            self._rows = [row.tobytes() for row in table.view(np.uint8)]
        self._index = index
        return index

    def _build_table(self) -> npt.NDArray[np.bool_] | None:
        if not self._tabulate:
            return None
        x_min, x_max, y_min, y_max = self.grid
        xs, ys = np.meshgrid(np.arange(x_min, x_max + 1, dtype=float),
                             np.arange(y_min, y_max + 1, dtype=float), indexing="ij")
        pts = np.column_stack([xs.ravel(), ys.ravel()])
        n = len(pts)
        if n * n > _MAX_TABLE_CELLS:
            _log.info("grid has %d points; collision answers are cached, not tabulated", n)
            self._tabulate = False
            return None
        i, j = np.triu_indices(n, k=1)
        coords = np.stack([pts[i], pts[j]], axis=1)
        lines = shapely.linestrings(coords)
        table = np.zeros((n, n), dtype=bool)
        table[i, j] = shapely.intersects(self.union, lines)
        table |= table.T
        table[np.arange(n), np.arange(n)] = shapely.intersects(self.union, shapely.points(pts))
        self._table = table
        _log.debug("collision table built for %d grid points", n)
        return table


def _parts(geometry: shapely.Geometry) -> list[Polygon]:
    """The polygons of a polygon or multipolygon (none when it is empty)."""
    if geometry.is_empty:
        return []
    return list(getattr(geometry, "geoms", [geometry]))
