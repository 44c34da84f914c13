"""hugrt: ray shooting on numpy arrays.

Scenes come from arrays (``Scene.from_arrays``), files (``load``: NFF, PLY, OBJ, STL, glTF, each
optionally gzip-compressed) or hugrt's generated scenes (``Scene.open("builtin:kitchen")``).
``scene.build(structure, **settings)`` builds one of ``structures()`` (the Hierarchy of
Uniform Grids ``"hug"``, ``"grid"``, ``"bvh"``, ...); the structure answers batch queries
with numpy arrays in and out, on hugrt's threads with the interpreter's lock released::

    import numpy as np, hugrt
    scene = hugrt.Scene.from_arrays(vertices, faces)
    accel = scene.build("bvh")
    t, prim, u, v = accel.intersect(origins, directions)
    blocked = accel.occluded(origins, directions, tmax=1.0)
    offsets, t_all, prim_all, u_all, v_all = accel.intersect_all(origins, directions)

``hugrt.trimesh.RayMeshIntersector(mesh)`` is a ray backend for trimesh;
``hugrt.distributed`` runs tiled renders and sweeps as Ray tasks.
"""

from ._hugrt import (
    Accel,
    Scene,
    __version__,
    load,
    reproduce,
    reproduce_targets,
    settings,
    structures,
)

__all__ = [
    "Accel",
    "Scene",
    "__version__",
    "load",
    "reproduce",
    "reproduce_targets",
    "settings",
    "structures",
]
