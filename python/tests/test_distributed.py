"""hugrt.distributed on a local Ray cluster started here (skipped where Ray is not installed
or cannot start): the tiled image equals the single-process one pixel for pixel, and a sweep
and a reproduce target run as tasks."""

import numpy as np
import pytest

import hugrt

ray = pytest.importorskip("ray", reason="Ray is not installed (pip install 'ray[default]')")
import hugrt.distributed as dist  # noqa: E402


@pytest.fixture(scope="module")
def cluster():
    try:
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    except Exception as e:  # pragma: no cover - depends on the machine
        pytest.skip(f"a local Ray cluster could not start: {e}")
    yield
    ray.shutdown()


def test_a_tiled_render_is_the_whole_image(cluster):
    whole = hugrt.Scene.open("builtin:kitchen").build("hug").render(96, 64, depth=3)
    tiled = dist.render_tiled("builtin:kitchen", 96, 64, structure="hug", depth=3, band=10)
    assert tiled.shape == whole.shape
    assert np.array_equal(tiled, whole)
    assert whole.max() > 0.1


def test_a_tiled_render_of_arrays_with_settings(cluster):
    rng = np.random.default_rng(0)
    v = rng.random((600, 3)).astype(np.float32)
    f = rng.integers(0, 600, (200, 3))
    local = hugrt.Scene.from_arrays(v, f).build("grid", density=4).render(40, 30, depth=1)
    tiled = dist.render_tiled((v, f), 40, 30, structure="grid", depth=1, band=7, density=4)
    assert np.array_equal(tiled, local)


def test_a_sweep_measures_every_spec_on_every_scene(cluster):
    rows = dist.sweep(["builtin:kitchen", "builtin:building:2"], ["hug", "bvh", "grid:density=8"], n=2000, repeat=1)
    assert [(r["scene"], r["spec"]) for r in rows] == [
        (s, spec) for s in ["builtin:kitchen", "builtin:building:2"] for spec in ["hug", "bvh", "grid:density=8"]
    ]
    # Every structure answers the same rays the same way: the hit counts agree per scene.
    for s in ["builtin:kitchen", "builtin:building:2"]:
        hits = {r["hits"] for r in rows if r["scene"] == s}
        assert len(hits) == 1 and hits.pop() > 0
    assert all(r["mrays_per_second"] > 0 and r["build_seconds"] >= 0 for r in rows)
    with pytest.raises(ValueError, match="rays must be"):
        dist.sweep(["builtin:kitchen"], ["hug"], rays="sideways")


def test_reproduce_targets_run_as_tasks(cluster, tmp_path):
    folders = dist.reproduce(["scg97-scenes"], str(tmp_path), quick=True)
    assert len(folders) == 1
    assert (tmp_path / "scg97-scenes" / "report.md").exists()
