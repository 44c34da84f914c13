"""hugrt's trimesh backend against trimesh's own pure-Python intersector (brute force over an
r-tree's candidates, in float64 with a tolerance around each triangle), on meshes from
trimesh's generators with rays through vertices, through edges and along edges: hugrt must
find every hit that trimesh's intersector finds."""

import numpy as np
import pytest

trimesh = pytest.importorskip("trimesh")
pytest.importorskip("rtree", reason="trimesh's pure-Python intersector needs rtree")

import hugrt.trimesh  # noqa: E402
from trimesh.ray.ray_triangle import RayMeshIntersector as Reference  # noqa: E402


def float32_mesh(mesh):
    """The mesh with float32-exact vertices, so that hugrt (float32 geometry) and the
    reference (float64) intersect the same triangles."""
    return trimesh.Trimesh(
        vertices=mesh.vertices.astype(np.float32).astype(np.float64), faces=mesh.faces, process=False
    )


def meshes():
    rng = np.random.default_rng(5)
    soup = trimesh.Trimesh(
        vertices=rng.random((120, 3)), faces=rng.integers(0, 120, (80, 3)), process=False
    )
    soup.update_faces(soup.nondegenerate_faces())
    return {
        "icosphere": float32_mesh(trimesh.creation.icosphere(subdivisions=2)),
        "box": trimesh.creation.box(extents=(1, 1, 1)),
        "soup": float32_mesh(soup),
        "cylinder": float32_mesh(trimesh.creation.cylinder(radius=0.5, height=1.0, sections=12)),
    }


def rays_at(mesh, seed):
    """Rays from outside the mesh's box through every vertex, every edge's midpoint and random
    points, plus rays along edges (from beyond one end, through both vertices)."""
    rng = np.random.default_rng(seed)
    v = mesh.vertices
    edges = mesh.edges_unique
    centre = mesh.bounds.mean(axis=0)
    size = np.linalg.norm(mesh.extents)
    targets = np.concatenate(
        [v, v[edges].mean(axis=1), mesh.bounds[0] + rng.random((200, 3)) * mesh.extents]
    )
    away = rng.standard_normal(targets.shape)
    away /= np.linalg.norm(away, axis=1)[:, None]
    origins = targets + away * 2 * size
    directions = targets - origins
    # Along edges: start one edge length before the first vertex.
    a, b = v[edges[:, 0]], v[edges[:, 1]]
    along_o = a - (b - a)
    along_d = b - a
    o = np.concatenate([origins, along_o, centre + 0 * along_o[:5]])
    d = np.concatenate([directions, along_d, rng.standard_normal((5, 3))])
    return o, d


def crossings(locations, index_ray, n, size):
    """Per ray, its hit points merged where closer than a millionth of the size."""
    out = [[] for _ in range(n)]
    for p, r in zip(locations, index_ray):
        if not any(np.linalg.norm(p - q) <= 1e-6 * size for q in out[r]):
            out[r].append(p)
    return out


def well_posed(mesh, name, size):
    """Whether a hit at point `p` of ray direction `d` is one float32 rounding cannot take
    away. On a convex mesh, a crossing: the ray is strictly inside just before or just after
    (a ray that only touches a vertex or runs along the surface is decided by rounding, in
    any float arithmetic). In the soup, a hit well inside a triangle."""
    if name == "soup":
        tri = mesh.triangles

        def inside_a_triangle(p, d):
            b = trimesh.triangles.points_to_barycentric(tri, np.repeat([p], len(tri), axis=0))
            near = np.abs(trimesh.triangles.points_to_barycentric(tri, np.repeat([p], len(tri), axis=0)) @ np.ones(3) - 1) < 1e-9
            on = near & (np.abs(np.einsum("ij,ij->i", mesh.face_normals, p - tri[:, 0])) < 1e-6 * size)
            return bool(on.any()) and bool((b[on] > 1e-4).all(axis=1).all())

        return inside_a_triangle
    normals, origins = mesh.face_normals, mesh.triangles[:, 0]

    def crossing(p, d):
        step = 1e-3 * size * d / np.linalg.norm(d)
        depth = lambda q: np.max(np.einsum("ij,ij->i", normals, q - origins))
        return depth(p - step) < -1e-6 * size or depth(p + step) < -1e-6 * size

    return crossing


@pytest.mark.parametrize("name", ["icosphere", "box", "soup", "cylinder"])
@pytest.mark.parametrize("structure", ["bvh", "hug", "grid"])
def test_hugrt_finds_every_hit_the_reference_finds(name, structure):
    mesh = meshes()[name]
    o, d = rays_at(mesh, seed=len(name))
    ours = hugrt.trimesh.RayMeshIntersector(mesh, structure=structure)
    ref = Reference(mesh)
    size = np.linalg.norm(mesh.extents)
    required = well_posed(mesh, name, size)

    if name == "soup":
        # Few edges are shared in a soup: a hit well inside a triangle is that triangle's.
        tri_ref, ray_ref, loc_ref = ref.intersects_id(o, d, return_locations=True)
        tri_ours, ray_ours = ours.intersects_id(o, d)
        have = set(zip(ray_ours, tri_ours))
        checked = [(r, t) for r, t, p in zip(ray_ref, tri_ref, loc_ref) if required(p, d[r])]
        assert len(checked) > len(o) // 2
        missed = [c for c in checked if c not in have]
        assert not missed, f"{len(missed)} of {len(checked)} hits missed, e.g. {missed[0]}"
        return

    loc_ref, ray_ref, _ = ref.intersects_location(o, d)
    loc_ours, ray_ours, tri_ours = ours.intersects_location(o, d)
    want = crossings(loc_ref, ray_ref, len(o), size)
    got = crossings(loc_ours, ray_ours, len(o), size)
    # A float32 hit on a triangle seen edge-on lies up to ~1e-5 of the size away from the
    # float64 one.
    near = lambda p, points: any(np.linalg.norm(p - q) <= 1e-4 * size for q in points)
    # Every well-posed hit the reference finds, hugrt finds (to a float32 rounding) ...
    checked = [(i, p) for i in range(len(o)) for p in want[i] if required(p, d[i])]
    missed = [(i, p) for i, p in checked if not near(p, got[i])]
    assert len(checked) > len(o) // 2
    assert not missed, f"{len(missed)} of {len(checked)} hits missed, e.g. ray {missed[0][0]} at {missed[0][1]}"
    # ... and every well-posed hit of hugrt's is the reference's.
    extra = [(i, p) for i in range(len(o)) for p in got[i] if required(p, d[i]) and not near(p, want[i])]
    assert not extra, f"{len(extra)} hits the reference does not have, e.g. ray {extra[0][0]} at {extra[0][1]}"

    # The first hit: the same point as the reference's nearest.
    # The first hit: hugrt's nearest point is the reference's nearest where that is
    # well posed.
    first = ours.intersects_first(o, d)
    t_ours = ours.accel.intersect(o, d)[0]
    for i in range(len(o)):
        if want[i]:
            p = min(want[i], key=lambda p: np.dot(p - o[i], d[i]))
            if required(p, d[i]):
                assert first[i] >= 0
                assert np.allclose(o[i] + t_ours[i] * d[i], p, atol=1e-4 * size)

    # Any hit: exactly the rays with a first hit.
    hit = ours.intersects_any(o, d)
    assert hit.dtype == np.bool_
    assert (hit == (first >= 0)).all()
    assert tri_ours.dtype == np.int64 and ray_ours.dtype == np.int64


def test_on_the_box_every_hit_is_found_exactly():
    """On a box at +-0.5, axis rays through its corners and along its edges are exact in
    float32: a ray along an edge touches the faces at both ends of it, at their corners, and
    the reference and hugrt agree on every one of those hits, triangle for triangle."""
    mesh = trimesh.creation.box(extents=(1, 1, 1))
    o, d = [], []
    for axis in range(3):
        for a in (-0.5, 0.0, 0.5, 0.25):
            for b in (-0.5, 0.0, 0.5):
                origin = np.zeros(3)
                origin[axis] = -2.0
                origin[(axis + 1) % 3], origin[(axis + 2) % 3] = a, b
                direction = np.zeros(3)
                direction[axis] = 1.0
                o.append(origin)
                d.append(direction)
    o, d = np.array(o), np.array(d)
    ref = Reference(mesh)
    want = sorted(zip(*ref.intersects_id(o, d)))
    for structure in ["bvh", "hug", "grid", "kdtree"]:
        got = sorted(zip(*hugrt.trimesh.RayMeshIntersector(mesh, structure=structure).intersects_id(o, d)))
        assert got == want
    assert len(want) > 2 * len(o)


def test_multiple_hits_and_their_cap():
    mesh = trimesh.creation.icosphere(subdivisions=3)
    ours = hugrt.trimesh.RayMeshIntersector(mesh)
    o = np.array([[0.013, 0.021, -5.0], [0.1, 0.2, -5], [3, 3, -5], [0, 0, -5]])
    d = np.array([[0, 0, 1.0], [0, 0, 1], [0, 0, 1], [0, 0, 1]])
    tri, ray = ours.intersects_id(o, d)
    # The last ray passes through the poles, vertices of 6 triangles each: every one of
    # them is hit, and its locations merge into two.
    assert list(np.bincount(ray, minlength=4)) == [2, 2, 0, 12]
    _, ray_at, _ = ours.intersects_location(o, d)
    assert list(np.bincount(ray_at, minlength=4)) == [2, 2, 0, 2]
    o, d = o[:3], d[:3]
    tri, ray = ours.intersects_id(o, d)
    tri1, ray1 = ours.intersects_id(o, d, multiple_hits=False)
    assert list(ray1) == [0, 1]
    assert set(tri1) <= set(tri)
    tri2, ray2 = ours.intersects_id(o, d, max_hits=1)
    assert list(ray2) == [0, 1] and list(tri2) == list(tri1)
    tri3, ray3, loc = ours.intersects_id(o, d, return_locations=True)
    assert loc.shape == (4, 3)
    assert np.allclose(np.linalg.norm(loc, axis=1), 1, atol=2e-2)


def test_one_line_switches_a_meshs_engine_and_contains_works():
    mesh = trimesh.creation.icosphere(subdivisions=3)
    mesh.ray = hugrt.trimesh.RayMeshIntersector(mesh)
    rng = np.random.default_rng(0)
    points = rng.uniform(-1.2, 1.2, (2000, 3))
    r = np.linalg.norm(points, axis=1)
    inside = mesh.contains(points)
    # The icosphere is inscribed in the unit sphere: well inside and well outside are clear.
    assert inside[r < 0.95].all()
    assert not inside[r > 1.0].any()
    # The mesh changed: the structure follows.
    mesh.vertices = mesh.vertices * 2
    assert mesh.contains([[1.5, 0, 0]])[0]


def test_shapes_are_checked():
    mesh = trimesh.creation.box()
    ours = hugrt.trimesh.RayMeshIntersector(mesh)
    with pytest.raises(ValueError, match=r"must both have shape \(n, 3\)"):
        ours.intersects_first(np.zeros((3, 3)), np.zeros((2, 3)))
