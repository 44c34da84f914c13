"""hugrt's Python API against brute force: the compiled module's plumbing (arrays in and out,
dtypes, errors, threads) and every structure's answers."""

import threading

import numpy as np
import pytest

import hugrt


def soup(n, seed=0, size=0.1):
    """n random triangles in the unit cube, each within `size` of its first vertex."""
    rng = np.random.default_rng(seed)
    a = rng.random((n, 3))
    v = np.concatenate([a, a + size * rng.standard_normal((n, 3)), a + size * rng.standard_normal((n, 3))])
    faces = np.stack([np.arange(n), np.arange(n) + n, np.arange(n) + 2 * n], axis=1)
    return v.astype(np.float32), faces


def rays(n, seed=1):
    rng = np.random.default_rng(seed)
    o = rng.random((n, 3)) * 1.4 - 0.2
    d = rng.standard_normal((n, 3))
    return o, d


def moller_trumbore(v, f, o, d):
    """Closest t per ray by a plain vectorised Möller–Trumbore in float64 (n × m)."""
    a, b, c = (v[f[:, k]].astype(np.float64) for k in range(3))
    e1, e2 = b - a, c - a
    p = np.cross(d[:, None, :], e2[None])
    det = np.einsum("mk,nmk->nm", e1, p)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = o[:, None, :] - a[None]
        u = np.einsum("nmk,nmk->nm", s, p) * inv
        q = np.cross(s, e1[None])
        w = np.einsum("nk,nmk->nm", d, q) * inv
        t = np.einsum("mk,nmk->nm", e2, q) * inv
    ok = (np.abs(det) > 1e-12) & (u >= 0) & (w >= 0) & (u + w <= 1) & (t >= 0)
    t = np.where(ok, t, np.inf)
    return t.min(axis=1), np.where(np.isfinite(t.min(axis=1)), t.argmin(axis=1), -1)


def test_every_structure_finds_brute_forces_closest_hits():
    v, f = soup(300)
    scene = hugrt.Scene.from_arrays(v, f)
    o, d = rays(2000)
    want_t, want_prim = moller_trumbore(v, f, o, d)
    brute = scene.build("brute")
    bt, bp, _, _ = brute.intersect(o, d)
    # hugrt's brute force is the float32 watertight test: it agrees with a float64
    # Möller–Trumbore wherever the hit is not within rounding of an edge.
    assert np.mean(bp == want_prim) > 0.99
    close = np.isfinite(want_t)
    assert np.allclose(bt[close & (bp == want_prim)], want_t[close & (bp == want_prim)], rtol=1e-4)
    for name in hugrt.structures():
        t, prim, u, w = scene.build(name).intersect(o, d)
        same = (prim == bp) | (t == bt)
        assert same.all(), f"{name}: {np.count_nonzero(~same)} rays differ from brute force"


def test_barycentrics_rebuild_the_hit_point():
    v, f = soup(200, seed=3)
    o, d = rays(1000, seed=4)
    t, prim, u, w = hugrt.Scene.from_arrays(v, f).build("hug").intersect(o, d)
    hit = prim >= 0
    assert hit.sum() > 100
    tri = v[f[prim[hit]]].astype(np.float64)
    p = (1 - u[hit] - w[hit])[:, None] * tri[:, 0] + u[hit][:, None] * tri[:, 1] + w[hit][:, None] * tri[:, 2]
    q = o[hit] + d[hit] * t[hit][:, None]
    assert np.allclose(p, q, atol=1e-4)
    assert ((u[hit] >= -1e-4) & (w[hit] >= -1e-4) & (u[hit] + w[hit] <= 1 + 1e-4)).all()
    assert (u[~hit] == 0).all() and np.isinf(t[~hit]).all() and (prim[~hit] == -1).all()
    # Without barycentrics: the same hits, the weights left at 0.
    t2, prim2, u2, w2 = hugrt.Scene.from_arrays(v, f).build("hug").intersect(o, d, barycentrics=False)
    assert np.array_equal(t2, t) and np.array_equal(prim2, prim)
    assert not u2.any() and not w2.any()


def test_occluded_is_a_hit_within_the_interval():
    v, f = soup(300, seed=5)
    scene = hugrt.Scene.from_arrays(v, f)
    o, d = rays(3000, seed=6)
    tmax = np.random.default_rng(7).random(3000).astype(np.float32)
    for name in ["hug", "bvh", "grid"]:
        accel = scene.build(name)
        t, _, _, _ = accel.intersect(o, d, tmax=tmax)
        blocked = accel.occluded(o, d, tmax=tmax)
        assert blocked.dtype == np.bool_
        assert (blocked == np.isfinite(t)).all()
        assert (t[np.isfinite(t)] <= tmax[np.isfinite(t)]).all()


def test_intersect_all_lists_every_hit_in_order():
    v, f = soup(400, seed=8, size=0.3)
    scene = hugrt.Scene.from_arrays(v, f)
    o, d = rays(500, seed=9)
    want = scene.build("brute").intersect_all(o, d)
    for name in ["hug", "bvh", "kdtree"]:
        accel = scene.build(name)
        offsets, t, prim, u, w = accel.intersect_all(o, d)
        assert len(offsets) == len(o) + 1 and offsets[0] == 0 and offsets[-1] == len(t)
        assert (np.diff(offsets) >= 0).all()
        assert np.array_equal(offsets, want[0]) and np.array_equal(prim, want[2])
        first_t, first_prim, _, _ = accel.intersect(o, d)
        for i in range(len(o)):
            ts = t[offsets[i] : offsets[i + 1]]
            assert (np.diff(ts) >= 0).all()
            if len(ts):
                assert ts[0] == first_t[i]
            else:
                assert first_prim[i] == -1
    assert want[0][-1] > len(o), "the soup should give rays several hits"


def test_arrays_of_any_float_or_int_type_and_lists():
    v, f = soup(50, seed=10)
    o, d = rays(100, seed=11)
    base = hugrt.Scene.from_arrays(v, f).build("bvh").intersect(o, d)
    for vv, ff in [(v.astype(np.float64), f.astype(np.int32)), (v.tolist(), f.astype(np.uint32).tolist())]:
        got = hugrt.Scene.from_arrays(vv, ff).build("bvh").intersect(o.astype(np.float32), d.tolist())
        for a, b in zip(base, got):
            assert np.array_equal(a, b)
    # Strided views are read as they are.
    wide = np.zeros((100, 6))
    wide[:, ::2] = o
    got = hugrt.Scene.from_arrays(v, f).build("bvh").intersect(wide[:, ::2], d)
    assert np.array_equal(got[0], base[0])


def test_bad_arrays_get_a_clear_error():
    v, f = soup(10)
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        hugrt.Scene.from_arrays(v[:, :2], f)
    with pytest.raises(ValueError, match="refers to vertex 99"):
        hugrt.Scene.from_arrays(v, np.array([[0, 1, 99]]))
    with pytest.raises(ValueError, match="refers to vertex -1"):
        hugrt.Scene.from_arrays(v, np.array([[0, 1, -1]]))
    with pytest.raises(ValueError, match="integers"):
        hugrt.Scene.from_arrays(v, f.astype(np.float64))
    bad = v.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"vertices\[3\].*not finite"):
        hugrt.Scene.from_arrays(bad, f)
    accel = hugrt.Scene.from_arrays(v, f).build("grid")
    o, d = rays(5)
    with pytest.raises(ValueError, match="5 origins for 4 directions"):
        accel.intersect(o, d[:4])
    with pytest.raises(ValueError, match="tmax has 3 values for 5 rays"):
        accel.intersect(o, d, tmax=[1, 2, 3])
    with pytest.raises(ValueError, match="threads must be at least 1"):
        accel.intersect(o, d, threads=0)


def test_settings_are_keywords_checked_by_the_structure():
    v, f = soup(100)
    scene = hugrt.Scene.from_arrays(v, f)
    assert scene.build("hug", preset="eg95").spec == "hug:preset=eg95"
    assert scene.build("grid", density=8, simd=False).spec == "grid:density=8,simd=false"
    assert scene.build("grid:density=8", simd=False).spec == "grid:density=8,simd=false"
    with pytest.raises(ValueError, match="no key 'nope'; valid keys"):
        scene.build("grid", nope=1)
    with pytest.raises(ValueError, match="unknown structure 'grd'"):
        scene.build("grd")
    with pytest.raises(ValueError, match="density"):
        scene.build("grid", density=-1)
    with pytest.raises(ValueError, match="not a value"):
        scene.build("grid", density="1,prune=2")
    names = [k["name"] for k in hugrt.settings("grid")]
    assert "density" in names
    with pytest.raises(ValueError, match="unknown structure"):
        hugrt.settings("nope")


def test_threads_do_not_change_answers_and_the_lock_is_released():
    v, f = soup(3000, seed=12)
    accel = hugrt.Scene.from_arrays(v, f).build("brute")
    o, d = rays(4000, seed=13)
    one = accel.intersect(o, d, threads=1)
    two = accel.intersect(o, d, threads=2)
    for a, b in zip(one, two):
        assert np.array_equal(a, b)
    # While a long query runs on another thread, this thread keeps running Python: it
    # could not if the query held the interpreter's lock.
    done = threading.Event()
    ticks = 0

    def work():
        accel.intersect(o, d, threads=1)
        done.set()

    worker = threading.Thread(target=work)
    worker.start()
    while not done.is_set():
        ticks += 1
    worker.join()
    assert ticks > 1000, f"only {ticks} iterations ran beside the query"


def test_stats_describe_the_structure():
    v, f = soup(500)
    accel = hugrt.Scene.from_arrays(v, f).build("hug")
    s = accel.stats()
    assert s["structure"] == "hug" and s["spec"] == "hug" and s["primitives"] == 500
    assert s["memory_bytes"] == accel.memory_bytes > 0
    assert s["entries"]["grids"] >= 1
    assert s["census"]["cells"] >= 1
    assert len(s["levels"]) >= 1


def test_files_load_and_their_errors_name_the_file_and_line(tmp_path):
    v, f = soup(20)
    p = tmp_path / "soup.obj"
    lines = [f"v {a} {b} {c}" for a, b, c in v] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f]
    p.write_text("\n".join(lines) + "\n")
    scene = hugrt.load(p)
    assert len(scene) == 20
    o, d = rays(300)
    want = hugrt.Scene.from_arrays(v, f).build("bvh").intersect(o, d)
    got = scene.build("bvh").intersect(o, d)
    assert np.array_equal(want[1], got[1])
    bad = tmp_path / "bad.nff"
    bad.write_text("s 0 0 0 1\ns 0 0 zero 1\n")
    with pytest.raises(ValueError, match=r"bad.nff:2:"):
        hugrt.load(bad)
    with pytest.raises(OSError, match="missing.ply"):
        hugrt.load(tmp_path / "missing.ply")
    assert len(hugrt.Scene.open("builtin:kitchen")) > 1000


def test_a_band_of_rows_is_those_rows_of_the_image():
    accel = hugrt.Scene.open("builtin:kitchen").build("hug")
    whole = accel.render(48, 40, depth=2)
    assert whole.shape == (40, 48, 3) and whole.dtype == np.float32
    bands = [accel.render(48, 40, depth=2, rows=(y, min(y + 7, 40))) for y in range(0, 40, 7)]
    assert np.array_equal(np.concatenate(bands), whole)
    assert whole.max() > 0.1
    with pytest.raises(ValueError, match="rows"):
        accel.render(48, 40, rows=(30, 50))


def test_generated_rays_frame_the_scene():
    scene = hugrt.Scene.open("builtin:kitchen")
    o, d = scene.camera_rays(16, 8)
    assert o.shape == (128, 3) and d.shape == (128, 3)
    t, _, _, _ = scene.build("bvh").intersect(o, d)
    assert 0.05 < np.isfinite(t).mean() < 1, "the box is framed from outside, with space around it"
    o, d = scene.incoherent_rays(100, seed=2)
    lo, hi = scene.bounds
    assert ((o >= lo) & (o <= hi)).all()
    assert np.allclose(np.linalg.norm(d, axis=1), 1, atol=1e-5)


def test_camera_rays_walked_together_hit_as_brute_force():
    # A camera's neighbouring rays are walked as packets where a structure's packet walk pays
    # (the bvh's): every ray's answer must still be its own.
    scene = hugrt.Scene.open("builtin:kitchen")
    o, d = scene.camera_rays(64, 48)
    bt, bp, _, _ = scene.build("brute").intersect(o, d)
    blocked = scene.build("brute").occluded(o, d)
    assert 0.05 < np.isfinite(bt).mean() < 1
    for name in ["bvh", "hug", "grid"]:
        accel = scene.build(name)
        for packets in ["auto", "on", "off"]:
            t, prim, _, _ = accel.intersect(o, d, packets=packets)
            same = (prim == bp) | (t == bt)
            assert same.all(), (
                f"{name}, packets={packets}: {np.count_nonzero(~same)} rays differ from brute force"
            )
            assert (accel.occluded(o, d, packets=packets) == blocked).all()


def test_an_unknown_packets_mode_is_named():
    accel = hugrt.Scene.open("builtin:kitchen").build("bvh")
    o, d = np.zeros((1, 3)), np.ones((1, 3))
    for query in [accel.intersect, accel.occluded]:
        with pytest.raises(ValueError, match="unknown packets mode `sometimes`"):
            query(o, d, packets="sometimes")
