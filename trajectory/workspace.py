"""The obstacles of a scene, indexed once, and the fast `collision` external built on them.

The grounder evaluates ``collision(X1,Y1,X2,Y2)`` for every pair of grid points a law
mentions (tens of thousands of calls), so the answer for integer points inside the grid comes
from a table computed in one vectorised shapely call the first time it is needed; any other
argument goes through an STRtree query and an LRU cache.
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

    # -- queries ---------------------------------------------------------------------------
    def hits(self, geometry: shapely.Geometry) -> list[int]:
        """Indices of the obstacles that meet ``geometry`` (interior or boundary)."""
        return [int(i) for i in self.tree.query(geometry, predicate="intersects")]

    def candidates(self, points: Sequence[Point2]) -> list[int]:
        """Indices of obstacles whose bounding boxes meet the bounding box of ``points``."""
        xs = [p[0] for p in points]
        ys = [p[1] for p in points]
        return [int(i) for i in self.tree.query(shapely.box(min(xs), min(ys), max(xs), max(ys)))]

    def _segment_hits(self, x1: float, y1: float, x2: float, y2: float) -> bool:
        return bool(self.union.intersects(segment_geometry((x1, y1), (x2, y2))))

    def collision(self, x1: float, y1: float, x2: float, y2: float) -> bool:
        """True when the closed segment (x1,y1)-(x2,y2) meets an obstacle (a point if equal)."""
        index = self._grid_index(x1, y1)
        if index is not None:
            other = self._grid_index(x2, y2)
            if other is not None:
                table = self._table if self._table is not None else self._build_table()
                if table is not None:  # None: grid too large to tabulate
                    return bool(table[index, other])
        return self._cached(float(x1), float(y1), float(x2), float(y2))

    # -- the grid table --------------------------------------------------------------------
    def _grid_index(self, x: float, y: float) -> int | None:
        x_min, x_max, y_min, y_max = self.grid
        if isinstance(x, bool) or isinstance(y, bool):
            return None
        if not (float(x).is_integer() and float(y).is_integer()):
            return None
        ix, iy = int(x) - x_min, int(y) - y_min
        if 0 <= ix <= x_max - x_min and 0 <= iy <= y_max - y_min:
            return ix * (y_max - y_min + 1) + iy
        return None

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
