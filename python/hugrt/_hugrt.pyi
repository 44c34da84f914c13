"""Types of hugrt's compiled module (crates/hugrt-py)."""

from os import PathLike
from typing import Any, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

_Reals = npt.ArrayLike
_Bound = Union[float, npt.ArrayLike, None]

class Scene:
    @staticmethod
    def from_arrays(vertices: _Reals, faces: npt.ArrayLike) -> "Scene":
        """A triangle mesh: vertices (n, 3) floats, faces (m, 3) integer indices."""
    @staticmethod
    def open(name: str) -> "Scene":
        """A scene file or a built-in scene (``builtin:KIND[:SIZE]``)."""
    def build(self, structure: str, **settings: Any) -> "Accel":
        """A structure over the scene; settings are its keys (``hugrt.settings``)."""
    def __len__(self) -> int: ...
    @property
    def bounds(self) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    @property
    def memory_bytes(self) -> int: ...
    def incoherent_rays(
        self, n: int, seed: int = 1
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...
    def camera_rays(
        self, width: int, height: int
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32]]: ...

class Accel:
    def intersect(
        self,
        origins: _Reals,
        directions: _Reals,
        tmin: _Bound = None,
        tmax: _Bound = None,
        threads: Optional[int] = None,
        barycentrics: bool = True,
        packets: str = "auto",
    ) -> Tuple[
        npt.NDArray[np.float32],
        npt.NDArray[np.int64],
        npt.NDArray[np.float32],
        npt.NDArray[np.float32],
    ]:
        """Closest hits: (t, primitive, u, v); a miss is t = inf, primitive = -1.

        packets: "auto" (neighbouring rays walked together, 8 for the bvh and 32 for the
        grids, where they are coherent and the structure's packets pay), "on" or "off"; the
        same hits either way."""
    def occluded(
        self,
        origins: _Reals,
        directions: _Reals,
        tmin: _Bound = None,
        tmax: _Bound = None,
        threads: Optional[int] = None,
        packets: str = "auto",
    ) -> npt.NDArray[np.bool_]:
        """Whether anything is hit in [tmin, tmax]."""
    def intersect_all(
        self,
        origins: _Reals,
        directions: _Reals,
        tmin: _Bound = None,
        tmax: _Bound = None,
        threads: Optional[int] = None,
    ) -> Tuple[
        npt.NDArray[np.int64],
        npt.NDArray[np.float32],
        npt.NDArray[np.int64],
        npt.NDArray[np.float32],
        npt.NDArray[np.float32],
    ]:
        """Every hit in order of t: (offsets, t, primitive, u, v), flat, n + 1 offsets."""
    def stats(self) -> dict: ...
    def render(
        self,
        width: int = 512,
        height: int = 512,
        depth: int = 4,
        rows: Optional[Tuple[int, int]] = None,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.float32]:
        """SPD rendering: float32 radiance (rows, width, 3); ``rows`` renders a band."""
    @property
    def spec(self) -> str: ...
    @property
    def memory_bytes(self) -> int: ...

def load(path: Union[str, PathLike]) -> Scene: ...
def structures() -> list: ...
def settings(structure: str) -> list: ...
def reproduce(
    target: str,
    out_dir: Union[str, PathLike],
    quick: bool = False,
    spd_dir: Optional[Union[str, PathLike]] = None,
) -> str: ...
def reproduce_targets() -> list: ...
