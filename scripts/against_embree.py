#!/usr/bin/env python3
"""hugrt against Intel Embree on the same rays, paired round by round (a benchmark, not a test).

usage: against_embree.py --peer DIR [--hugrt BIN] [--work DIR] [--rounds 3] [--threads 2]
                         [--accel SPEC[@PACKETS]]... SCENE.ply...

DIR is a built embree-peer (its `embree_peer` and `gen_rays.py`). For each binary PLY scene (not
gzipped: embree-peer reads plain files; `hugrt gen KIND -o KIND.ply` writes the generated ones) it
writes three rays files: 1024x1024 camera rays and 1,000,000 incoherent rays (gen_rays.py), and
shadow rays from Embree's camera hits to a point light above the scene (any-hit, t in
[1e-4, 1], in pixel order). Each round runs Embree on each file, then `hugrt trace` with each
structure (`SPEC@on` sets `--packets on`, `SPEC@off` `--packets off`; the default is auto). The
table gives medians over the rounds of the Mrays/s ratio to Embree's in the same round, Embree's
build time over ours, and time to image on the camera rays ((build + trace) Embree's over
ours): above 1 is faster than Embree. After it, the same medians one row a scene (issue 19's
item 4 table: each structure's ratio on each kind of rays, its time to image, and its build
ratio in the camera, shadow and incoherent runs), and each column's range over the scenes.
Needs numpy.
"""
import argparse
import os
import re
import statistics
import subprocess
import sys

import numpy as np

RAY = np.dtype([("o", "<f4", 3), ("tmin", "<f4"), ("d", "<f4", 3), ("tmax", "<f4")])
HIT = np.dtype([("t", "<f4"), ("prim", "<u4")])


def run(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True)
    return out.stdout + out.stderr


def embree(peer, scene, rays, hits, threads, any_hit):
    cmd = [os.path.join(peer, "embree_peer"), scene, rays, hits, "--threads", str(threads)]
    out = run(cmd + (["--any-hit"] if any_hit else []))
    f = dict(re.findall(r"(\w+)=([\d.]+)", out))
    return float(f["build_ms"]), float(f["trace_ms_median"]), float(f["mrays_s"])


def hugrt(binary, scene, rays, hits, threads, spec, any_hit):
    accel, _, packets = spec.partition("@")
    cmd = [binary, "trace", scene, "--rays", rays, "--hits", hits, "--accel", accel,
           "--threads", str(threads), "--repeat", "5", "--packets", packets or "auto"]
    out = run(cmd + (["--any-hit"] if any_hit else []))
    m = re.search(r"build ([\d.]+) ms, trace ([\d.]+) ms, .* ([\d.]+) Mrays/s", out)
    if not m:
        sys.exit(f"unexpected output of {' '.join(cmd)}:\n{out}")
    return float(m[1]), float(m[2]), float(m[3])


def shadow_rays(camera, hits, lo, hi, out):
    """Rays from each camera hit to a light above the scene, in pixel order."""
    rays = np.fromfile(camera, RAY)
    h = np.fromfile(hits, HIT)
    hit = np.isfinite(h["t"])
    o = rays["o"][hit].astype(np.float64)
    d = rays["d"][hit].astype(np.float64)
    p = o + d * h["t"][hit, None].astype(np.float64)
    c = (lo + hi) / 2
    light = c + np.array([0.3, 1.0, 0.2]) * np.linalg.norm(hi - lo)
    s = np.zeros(len(p), RAY)
    s["o"], s["d"], s["tmin"], s["tmax"] = p, light - p, 1e-4, 1.0
    s.tofile(out)
    return len(s)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--peer", required=True)
    ap.add_argument("--hugrt", default="target/release/hugrt")
    ap.add_argument("--work", default="target/against-embree")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--accel", action="append")
    ap.add_argument("scenes", nargs="+")
    a = ap.parse_args()
    specs = a.accel or ["hug", "hug@on", "grid", "bvh", "bvh@off"]
    os.makedirs(a.work, exist_ok=True)
    sys.path.insert(0, a.peer)
    import gen_rays  # embree-peer's, for the scene box and the rays

    print("| scene | rays | structure | Mrays/s (Embree) | ×Embree | build ×Embree | time to image ×Embree |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    medians = {}
    for scene in a.scenes:
        name = os.path.basename(scene).split(".")[0]
        base = os.path.join(a.work, name)
        files = {k: f"{base}.{k}.rays" for k in ("camera", "shadow", "incoherent")}
        gen = os.path.join(a.peer, "gen_rays.py")
        run([sys.executable, gen, scene, files["camera"], "camera", "1024", "1024"])
        run([sys.executable, gen, scene, files["incoherent"], "incoherent", "1000000"])
        embree(a.peer, scene, files["camera"], f"{base}.embree.hits", a.threads, False)
        lo, hi = (np.array(x, np.float64) for x in gen_rays.bbox(scene))
        shadow_rays(files["camera"], f"{base}.embree.hits", lo, hi, files["shadow"])
        ratios = {}
        for _ in range(a.rounds):
            for kind, path in files.items():
                any_hit = kind == "shadow"
                eb, et, em = embree(a.peer, scene, path, f"{base}.embree.hits", a.threads, any_hit)
                for spec in specs:
                    hb, ht, hm = hugrt(a.hugrt, scene, path, f"{base}.hugrt.hits", a.threads,
                                       spec, any_hit)
                    r = ratios.setdefault((kind, spec), [])
                    r.append((hm, em, hm / em, eb / hb, (eb + et) / (hb + ht)))
        for (kind, spec), r in ratios.items():
            med = [statistics.median(x[i] for x in r) for i in range(5)]
            medians[name, kind, spec] = med
            tti = f"{med[4]:.2f}" if kind == "camera" else ""
            print(f"| {name} | {kind} | {spec} | {med[0]:.2f} ({med[1]:.2f}) | {med[2]:.2f} "
                  f"| {med[3]:.2f} | {tti} |", flush=True)
    summary(medians, specs)


def summary(medians, specs):
    """The medians one row a scene, and each column's range over the scenes."""
    kinds = ("camera", "shadow", "incoherent")
    columns = [(f"{spec} {kind}", lambda n, s=spec, k=kind: medians[n, k, s][2])
               for spec in specs for kind in kinds]
    columns += [(f"{spec} time to image", lambda n, s=spec: medians[n, "camera", s][4])
                for spec in specs]
    names = list(dict.fromkeys(n for n, _, _ in medians))
    print()
    print("| scene | " + " | ".join(c for c, _ in columns) + " | "
          + " | ".join(f"{spec} build ×Embree (camera, shadow, incoherent runs)"
                       for spec in specs) + " |")
    print("|" + " --- |" * (1 + len(columns) + len(specs)))
    for n in names:
        builds = [", ".join(f"{medians[n, k, s][3]:.2f}" for k in kinds) for s in specs]
        print(f"| {n} | " + " | ".join(f"{f(n):.2f}×" for _, f in columns) + " | "
              + " | ".join(builds) + " |")
    print()
    print("Ranges over the scenes: " + "; ".join(
        f"{c} {min(f(n) for n in names):.2f}–{max(f(n) for n in names):.2f}×"
        for c, f in columns) + ".")


if __name__ == "__main__":
    main()
