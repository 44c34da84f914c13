"""hugrt's work spread over machines as tasks of Ray (``pip install ray``): one large image
rendered in bands of rows, structures measured over many scenes, and ``hugrt reproduce``'s
targets, each a task on whatever cluster ``ray.init`` joined. hugrt schedules nothing itself.

A scene is named where every worker can open it: a file path all of them see, a built-in
scene (``"builtin:kitchen"``), or ``(vertices, faces)`` arrays, which Ray ships to the workers.
A worker builds each scene's structure once and keeps it for the tasks that follow.

A band of rows rendered apart is pixel for pixel the same as those rows of the whole image
(``Accel.render(rows=...)``), so the tiled image equals the single-process one exactly.
"""

import hashlib
import time
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple, Union

import numpy as np

from ._hugrt import Scene

__all__ = ["render_tiled", "sweep", "reproduce"]

SceneSource = Union[str, Tuple[np.ndarray, np.ndarray]]


def _ray():
    try:
        import ray
    except ImportError as e:  # pragma: no cover - depends on the machine
        raise ImportError("hugrt.distributed needs Ray: pip install 'ray[default]'") from e
    if not ray.is_initialized():
        ray.init()
    return ray


# Per worker process: structures already built, by (scene, structure, settings).
_BUILT: Dict[Any, Any] = {}


def _key(source: SceneSource, structure: str, settings: Dict[str, Any]):
    if isinstance(source, str):
        name = source
    else:
        digest = hashlib.blake2b(digest_size=16)
        for a in source:
            digest.update(np.ascontiguousarray(a).tobytes())
        name = ("arrays", digest.hexdigest())
    return (name, structure, tuple(sorted(settings.items())))


def _open(source: SceneSource) -> Scene:
    if isinstance(source, str):
        return Scene.open(source)
    vertices, faces = source
    return Scene.from_arrays(vertices, faces)


def _built(source: SceneSource, structure: str, settings: Dict[str, Any]):
    key = _key(source, structure, settings)
    if key not in _BUILT:
        start = time.perf_counter()
        accel = _open(source).build(structure, **settings)
        _BUILT[key] = (accel, time.perf_counter() - start)
    return _BUILT[key]


def _render_band(source, structure, settings, width, height, depth, rows, threads):
    accel, _ = _built(source, structure, settings)
    return rows, accel.render(width, height, depth=depth, rows=rows, threads=threads)


def render_tiled(
    scene: SceneSource,
    width: int,
    height: int,
    structure: str = "hug",
    depth: int = 4,
    band: int = 64,
    threads: int = 1,
    **settings: Any,
) -> np.ndarray:
    """Renders ``scene`` (SPD procedure, ``depth`` bounces) as bands of ``band`` rows, one Ray
    task each using ``threads`` threads (and asking Ray for as many CPUs); returns the
    height × width × 3 float32 radiance, equal to ``Accel.render``'s."""
    if band < 1:
        raise ValueError("band must be at least 1 row")
    ray = _ray()
    task = ray.remote(num_cpus=threads)(_render_band)
    shared = ray.put(scene) if not isinstance(scene, str) else scene
    futures = [
        task.remote(shared, structure, settings, width, height, depth, (y, min(y + band, height)), threads)
        for y in range(0, height, band)
    ]
    image = np.empty((height, width, 3), dtype=np.float32)
    for (y0, y1), pixels in ray.get(futures):
        image[y0:y1] = pixels
    return image


def _measure(source, spec, rays, n, repeat, threads):
    scene = _open(source)
    start = time.perf_counter()
    accel = scene.build(spec)
    build = time.perf_counter() - start
    if rays == "camera":
        side = int(np.sqrt(n))
        o, d = scene.camera_rays(side, side)
    else:
        o, d = scene.incoherent_rays(n)
    times = []
    for _ in range(max(1, repeat)):
        start = time.perf_counter()
        t, _, _, _ = accel.intersect(o, d, threads=threads)
        times.append(time.perf_counter() - start)
    trace = float(np.median(times))
    return {
        "scene": source if isinstance(source, str) else "arrays",
        "spec": spec,
        "rays": rays,
        "n": len(o),
        "hits": int(np.isfinite(t).sum()),
        "build_seconds": build,
        "trace_seconds": trace,
        "mrays_per_second": len(o) / trace / 1e6,
        "bytes_per_primitive": accel.memory_bytes / max(1, len(scene)),
    }


def sweep(
    scenes: Iterable[SceneSource],
    specs: Sequence[str],
    rays: str = "incoherent",
    n: int = 1_000_000,
    repeat: int = 3,
    threads: int = 1,
) -> List[Dict[str, Any]]:
    """Every structure spec (``"hug"``, ``"grid:density=8"``, ...) on every scene, one Ray task
    each: build seconds, the median trace time of ``n`` rays (``"incoherent"`` or
    ``"camera"``) over ``repeat`` runs, Mrays/s and bytes per primitive, in the order given.
    Times measured on different machines compare only as far as the machines do."""
    if rays not in ("incoherent", "camera"):
        raise ValueError(f"rays must be 'incoherent' or 'camera', not {rays!r}")
    ray = _ray()
    task = ray.remote(num_cpus=threads)(_measure)
    futures = [task.remote(s, spec, rays, n, repeat, threads) for s in scenes for spec in specs]
    return ray.get(futures)


def _reproduce(target, out_dir, quick, spd_dir):
    from ._hugrt import reproduce as run

    return str(run(target, out_dir, quick=quick, spd_dir=spd_dir))


def reproduce(
    targets: Iterable[str],
    out_dir: str,
    quick: bool = False,
    spd_dir: Optional[str] = None,
) -> List[str]:
    """``hugrt reproduce``'s targets, one Ray task each, writing to ``out_dir/TARGET`` (a folder
    every worker sees); returns the folders. The index page is ``hugrt reproduce``'s."""
    ray = _ray()
    task = ray.remote(num_cpus=1)(_reproduce)
    return ray.get([task.remote(t, out_dir, quick, spd_dir) for t in targets])
