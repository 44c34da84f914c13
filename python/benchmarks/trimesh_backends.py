"""hugrt's trimesh backend against trimesh with embreex and trimesh's pure-Python intersector:
whole calls from numpy in to numpy out, in one run, on the yardstick meshes.

    python python/benchmarks/trimesh_backends.py [--meshes DIR] [--rays N] [--repeat K] [--json OUT]

For each mesh: N incoherent rays (origins uniform in the box, directions uniform on the
sphere) and N camera rays (the box framed from outside, 45°), as embree-peer's gen_rays.py
makes them. Timed: `intersects_first`, `intersects_any` and `intersects_id(multiple_hits=True)`
(on N/10 rays), the median of K calls after a warm-up call, hugrt at 1 and 2 threads, embreex at
its own (Embree's threads: all cores). The pure-Python intersector runs on 200 rays drawn at
random, its time given per ray times N (it needs gigabytes for a few thousand rays on these
meshes).

Hits that differ between hugrt and embreex are arbitrated by a float64 brute force over every
triangle: a backend is right on a ray when its first hit's distance is the true nearest one
(relative 1e-4), or when both it and brute force miss.
"""

import argparse
import gzip
import io
import json
import os
import statistics
import sys
import time

import numpy as np
import trimesh

import hugrt
import hugrt.trimesh

MESHES = [
    "stanford-bunny.ply.gz",
    "nefertiti.ply.gz",
    "spd-tetra-big.ply.gz",
    "spd-teapot-big.ply.gz",
    "spd-mount-big.ply.gz",
]


def load(path):
    data = gzip.open(path).read() if path.endswith(".gz") else open(path, "rb").read()
    return trimesh.load(io.BytesIO(data), file_type="ply", process=False)


def timed(call, repeat):
    call()
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        out = call()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def brute_nearest(triangles, o, d, chunk=200_000):
    """True nearest distance per ray (inf on a miss), float64 Möller–Trumbore over all."""
    best = np.full(len(o), np.inf)
    for s in range(0, len(triangles), chunk):
        tri = triangles[s : s + chunk]
        a, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        for i in range(len(o)):
            p = np.cross(d[i], e2)
            det = np.einsum("ij,ij->i", e1, p)
            with np.errstate(divide="ignore", invalid="ignore"):
                inv = 1.0 / det
                q = o[i] - a
                u = np.einsum("ij,ij->i", q, p) * inv
                qe = np.cross(q, e1)
                v = qe @ d[i] * inv
                t = np.einsum("ij,ij->i", qe, e2) * inv
            ok = (np.abs(det) > 1e-300) & (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9) & (t >= 0)
            if ok.any():
                best[i] = min(best[i], t[ok].min())
    return best


def distance(mesh, o, d, tri):
    """Distance along each ray to the triangle it reports (inf for -1)."""
    out = np.full(len(o), np.inf)
    hit = tri >= 0
    if hit.any():
        t = mesh.triangles[tri[hit]]
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        with np.errstate(divide="ignore", invalid="ignore"):
            out[hit] = np.einsum("ij,ij->i", n, t[:, 0] - o[hit]) / np.einsum("ij,ij->i", n, d[hit])
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--meshes", default=os.path.join(os.path.dirname(__file__), "../../../shared/scenes/meshes"))
    ap.add_argument("--rays", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--json")
    ap.add_argument("--structure", default="bvh")
    args = ap.parse_args()
    try:
        from trimesh.ray.ray_pyembree import RayMeshIntersector as Embree
    except ImportError:
        sys.exit("trimesh's embreex backend is not installed: pip install embreex")
    from trimesh.ray.ray_triangle import RayMeshIntersector as PurePython

    rows = []
    for name in MESHES:
        path = os.path.join(args.meshes, name)
        if not os.path.exists(path):
            print(f"{name}: skipped (not in {args.meshes})", file=sys.stderr)
            continue
        mesh = load(path)
        scene = hugrt.Scene.from_arrays(mesh.vertices, mesh.faces)
        side = int(round(args.rays**0.5))
        kinds = {
            "incoherent": scene.incoherent_rays(args.rays, seed=1),
            "camera": scene.camera_rays(side, side),
        }
        embree = Embree(mesh)
        start = time.perf_counter()
        ours = hugrt.trimesh.RayMeshIntersector(mesh, structure=args.structure)
        ours.accel
        build = time.perf_counter() - start
        for kind, (o32, d32) in kinds.items():
            o, d = o32.astype(np.float64), d32.astype(np.float64)
            row = {"mesh": name, "triangles": len(mesh.faces), "rays": kind, "n": len(o), "hugrt_build_s": build}
            for call, n in (("intersects_first", len(o)), ("intersects_any", len(o)), ("intersects_id", len(o) // 10)):
                f = lambda b: getattr(b, call)(o[:n], d[:n], **({"multiple_hits": True} if call == "intersects_id" else {}))
                te, out_e = timed(lambda: f(embree), args.repeat)
                row[f"{call}_embreex_s"] = te
                for k in (1, 2):
                    ours.threads = k
                    th, out_h = timed(lambda: f(ours), args.repeat)
                    row[f"{call}_hugrt_{k}t_s"] = th
                if call == "intersects_first":
                    first_e, first_h = out_e, out_h
            # Hits that differ, and who is right.
            differ = np.nonzero(first_e != first_h)[0]
            row["first_differ"] = int(len(differ))
            sample = differ[:300]
            truth = brute_nearest(mesh.triangles, o[sample], d[sample])
            right = lambda tri: np.where(np.isinf(truth), tri < 0, np.isclose(distance(mesh, o[sample], d[sample], tri), truth, rtol=1e-4))
            row["differ_checked"] = int(len(sample))
            row["differ_embreex_right"] = int(right(first_e[sample]).sum())
            row["differ_hugrt_right"] = int(right(first_h[sample]).sum())
            # trimesh's pure-Python intersector, on 200 rays drawn at random (the first 200
            # camera rays are the top row, which misses).
            few = np.random.default_rng(0).choice(len(o), 200, replace=False)
            start = time.perf_counter()
            first_p = PurePython(mesh).intersects_first(o[few], d[few])
            row["intersects_first_purepython_s"] = (time.perf_counter() - start) / 200 * len(o)
            row["purepython_differ_of_200"] = int((first_p != first_h[few]).sum())
            rows.append(row)
            speed = lambda c: row[f"{c}_embreex_s"] / row[f"{c}_hugrt_2t_s"]
            print(
                f"{name:24} {kind:10} first {row['intersects_first_hugrt_2t_s']:.3f}s vs embreex "
                f"{row['intersects_first_embreex_s']:.3f}s ({speed('intersects_first'):.2f}x), any "
                f"{speed('intersects_any'):.2f}x, multiple {speed('intersects_id'):.2f}x; "
                f"{row['first_differ']} differ (hugrt right {row['differ_hugrt_right']}, embreex right "
                f"{row['differ_embreex_right']} of {row['differ_checked']})",
                flush=True,
            )
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
