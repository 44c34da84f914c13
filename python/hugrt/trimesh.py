"""A ray backend for trimesh, with the interface of ``trimesh.ray.ray_triangle.RayMeshIntersector``.

Switching a mesh's engine is one line::

    mesh.ray = hugrt.trimesh.RayMeshIntersector(mesh)

after which ``mesh.ray.intersects_location(...)``, ``mesh.contains(...)`` and the rest of
trimesh go through hugrt. Where it differs from trimesh's own backends, and why:

* The triangle test is watertight (Woop, Benthin and Wald 2013): a ray through a shared edge
  or vertex hits at least one of the triangles there, where embreex's default test can miss
  all of them. An edge's or a vertex's hit is reported for every triangle whose closed area
  holds it, as trimesh's pure-Python intersector does (it accepts a tolerance around each
  triangle), and ``intersects_location`` merges the hits of one ray at one point (closer
  than a millionth of the mesh's size), so that ``contains_points`` counts a crossing once.
* ``multiple_hits`` is one query per ray (every hit in order of distance), not rays shot
  again from offset origins: no hit is lost or counted twice at a point where the offset
  would have landed, and ``max_hits`` is only a cap on what is returned.
* Hits are in ``[0, inf)`` along each ray, in float32 arithmetic (hugrt's geometry), with
  locations computed in float64 from the caller's origins and directions.

The structure defaults to hugrt's ``bvh``, its fastest on the incoherent and camera rays
trimesh users send; any of ``hugrt.structures()`` can be chosen, with its settings.
"""

from typing import Any, Optional

import numpy as np

from ._hugrt import Scene

__all__ = ["RayMeshIntersector"]


class RayMeshIntersector:
    """Ray queries on a ``trimesh.Trimesh``, answered by a hugrt structure over its triangles.

    ``structure`` and ``settings`` choose the structure (``Scene.build``); ``threads`` caps
    the threads each query uses (all cores by default). The structure is rebuilt when the
    mesh changes (trimesh's hash of it).
    """

    def __init__(
        self,
        mesh: Any,
        structure: str = "bvh",
        threads: Optional[int] = None,
        **settings: Any,
    ) -> None:
        self.mesh = mesh
        self.structure = structure
        self.threads = threads
        self._settings = settings
        self._key = None
        self._accel = None

    @property
    def accel(self):
        """The hugrt structure over the mesh as it is now."""
        key = self.mesh.__hash__()
        if self._accel is None or key != self._key:
            scene = Scene.from_arrays(self.mesh.vertices, self.mesh.faces)
            self._accel = scene.build(self.structure, **self._settings)
            self._key = key
        return self._accel

    def _rays(self, ray_origins, ray_directions):
        origins = np.asanyarray(ray_origins, dtype=np.float64)
        directions = np.asanyarray(ray_directions, dtype=np.float64)
        if origins.shape != directions.shape or origins.ndim != 2 or origins.shape[1] != 3:
            raise ValueError(
                f"ray_origins {origins.shape} and ray_directions {directions.shape} "
                "must both have shape (n, 3)"
            )
        return origins, directions

    def intersects_id(
        self,
        ray_origins,
        ray_directions,
        return_locations: bool = False,
        multiple_hits: bool = True,
        max_hits: Optional[int] = None,
        **kwargs: Any,
    ):
        """Triangles hit and the rays that hit them: ``(index_tri, index_ray[, locations])``.

        With ``multiple_hits`` every hit of each ray (in order of distance, at most
        ``max_hits`` a ray when given), otherwise the first. With ``return_locations`` the
        hit points too, hits at one point of one ray merged (trimesh's rule).
        """
        origins, directions = self._rays(ray_origins, ray_directions)
        accel = self.accel
        if multiple_hits:
            offsets, t, prim, _u, _v = accel.intersect_all(
                origins, directions, threads=self.threads
            )
            counts = np.diff(offsets)
            index_ray = np.repeat(np.arange(len(origins), dtype=np.int64), counts)
            index_tri = prim
            if max_hits is not None:
                rank = np.arange(len(prim), dtype=np.int64) - np.repeat(offsets[:-1], counts)
                keep = rank < max_hits
                index_ray, index_tri, t = index_ray[keep], index_tri[keep], t[keep]
        else:
            t, prim, _u, _v = accel.intersect(
                origins, directions, threads=self.threads, barycentrics=False
            )
            index_ray = np.nonzero(prim >= 0)[0].astype(np.int64)
            index_tri = prim[index_ray]
            t = t[index_ray]
        if not return_locations:
            return index_tri, index_ray
        locations = origins[index_ray] + directions[index_ray] * t[:, None].astype(np.float64)
        if len(index_tri) < 2:
            return index_tri, index_ray, locations.reshape(-1, 3)
        # One point of one ray hit on several triangles (an edge or a vertex shared by them)
        # is one location. Their distances can differ by a rounding, so points closer than
        # a millionth of the mesh's size (16 float32 steps of its largest coordinate: points
        # no float32 geometry tells apart) are merged, the first triangle kept.
        size = float(np.linalg.norm(np.ptp(self.mesh.vertices, axis=0))) or 1.0
        gap = np.linalg.norm(np.diff(locations, axis=0), axis=1)
        same = (index_ray[1:] == index_ray[:-1]) & (gap <= 1e-6 * size)
        keep = np.concatenate(([True], ~same))
        return index_tri[keep], index_ray[keep], locations[keep]

    def intersects_location(self, ray_origins, ray_directions, **kwargs: Any):
        """Distinct hit points: ``(locations, index_ray, index_tri)``."""
        index_tri, index_ray, locations = self.intersects_id(
            ray_origins, ray_directions, return_locations=True, **kwargs
        )
        return locations, index_ray, index_tri

    def intersects_first(self, ray_origins, ray_directions, **kwargs: Any):
        """The first triangle each ray hits, -1 where it hits none (int64)."""
        origins, directions = self._rays(ray_origins, ray_directions)
        _t, prim, _u, _v = self.accel.intersect(
            origins, directions, threads=self.threads, barycentrics=False
        )
        return prim

    def intersects_any(self, ray_origins, ray_directions, **kwargs: Any):
        """Whether each ray hits the mesh at all (bool)."""
        origins, directions = self._rays(ray_origins, ray_directions)
        return self.accel.occluded(origins, directions, threads=self.threads)

    def contains_points(self, points):
        """Whether each point is inside the mesh, by trimesh's ray-parity test."""
        from trimesh.ray.ray_util import contains_points

        return contains_points(self, points)
