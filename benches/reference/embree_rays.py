#!/usr/bin/env python3
"""External reference: Embree 4 ray-casting throughput (Mrays/s), via embreex.

What it measures
    Closest-hit and occlusion (any-hit) queries of incoherent rays against one
    triangle mesh, in Embree 4 through the `embreex` Python binding, in million
    rays per second (wall clock), for 1 or 2 threads; also the BVH build time
    and the hit fraction (so the Rust benchmark can cross-check its traversal).

    embreex traces one ray at a time (rtcIntersect1 / rtcOccluded1 in a Cython
    loop with the GIL released), so this is Embree's single-ray path, the same
    kind of query lodestar's BVH answers.  2 threads = the ray batch split in
    halves, each half run() in its own Python thread on the same scene.

Input (raw little-endian files in --data DIR, default <repo>/target/bench-data/)
    vertices.f32   N*3 float32 (x, y, z per vertex)
    triangles.u32  M*3 uint32 vertex indices
    rays.f32       R*6 float32 (origin xyz, direction xyz normalised);
                   tmin = 0, tmax = inf (embreex uses 1e37 as "infinite")

How to run
    pip install embreex numpy
    python3 benches/reference/embree_rays.py --generate target/bench-data   # test data
    python3 benches/reference/embree_rays.py --data target/bench-data --threads 1
    python3 benches/reference/embree_rays.py --data target/bench-data --threads 2

    --generate DIR writes a noisy sphere (~1M triangles: 6 cube faces, each an
    equi-angular 289x289 quad grid projected to the unit sphere, radius
    displaced by a sum of sinusoid products, bumps of about +-0.17) and
    --rays rays (default 2M; the Rust benchmark uses 10M) with origins uniform
    in the mesh AABB and directions uniform on the sphere, numpy
    default_rng(1).

Output lines (one per measurement)
    embree build threads=T build_s=X (upload_s=.. commit_s=..) cpu_s=.. triangles=M
    embree closest threads=T mrays_per_s=X wall_s=.. cpu_s=.. rays=R
    embree occlusion threads=T mrays_per_s=X wall_s=.. cpu_s=.. rays=R
    embree hit_fraction closest=F occlusion=F agreement=F
    upload_s is embreex copying the numpy buffers into Embree; commit_s is
    Embree's BVH build proper (compare lodestar's build with commit_s).
    A WARNING goes to stderr when cpu_s/wall_s < 0.85*threads (busy machine).

Notes
    --threads 1 pins the process to one CPU (os.sched_setaffinity) *before*
    Embree's TBB pool starts, so the BVH build is single-threaded too; with
    --threads 2 the build uses TBB's default pool (all cores).
    Each query is run --repeat times (default 3) and the best time is printed.

Packages: embreex (bundles Embree 4 + oneTBB), numpy.
"""

import argparse
import os
import sys
import threading
import time

import numpy as np


# --------------------------------------------------------------------------
# test-data generator
# --------------------------------------------------------------------------

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
GRID = 289  # quads per cube-face side -> 6 * 289^2 * 2 = 1,002,252 triangles


def _displacement(p):
    """Radius offset at unit-sphere point(s) p (..., 3): sum of sinusoid products."""
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    d = (0.1125 * np.sin(5.0 * x + 0.3) * np.sin(4.0 * y + 1.1) * np.sin(6.0 * z + 0.7)
         + 0.0625 * np.sin(13.0 * x + 2.0) * np.sin(11.0 * y + 0.4) * np.sin(12.0 * z + 1.9)
         + 0.0375 * np.sin(31.0 * x + 0.9) * np.sin(29.0 * y + 2.6) * np.sin(27.0 * z + 0.2))
    return d  # on the sphere: about -0.172 .. +0.155


def generate_mesh(grid=GRID):
    """Noisy sphere: cube faces with equi-angular grids, projected and displaced."""
    n = grid + 1
    a = np.tan(np.linspace(-np.pi / 4, np.pi / 4, n))  # equi-angular parameter
    a[0], a[-1] = -1.0, 1.0                             # exact cube edges
    u, v = np.meshgrid(a, a, indexing="xy")            # (n, n): u along columns
    u, v = u.ravel(), v.ravel()
    one = np.ones_like(u)
    # (normal axis, sign) -> cube point; orientation chosen so triangles face outwards
    faces = [
        np.stack([one, v, -u], -1),    # +x
        np.stack([-one, v, u], -1),    # -x
        np.stack([u, one, -v], -1),    # +y
        np.stack([u, -one, v], -1),    # -y
        np.stack([u, v, one], -1),     # +z
        np.stack([-u, v, -one], -1),   # -z
    ]
    verts = []
    tris = []
    idx = np.arange(n * n, dtype=np.uint32).reshape(n, n)
    i00 = idx[:-1, :-1].ravel()
    i10 = idx[:-1, 1:].ravel()
    i01 = idx[1:, :-1].ravel()
    i11 = idx[1:, 1:].ravel()
    quad_tris = np.concatenate([np.stack([i00, i10, i11], -1),
                                np.stack([i00, i11, i01], -1)], 0)
    for f, c in enumerate(faces):
        p = c / np.linalg.norm(c, axis=-1, keepdims=True)
        r = 1.0 + _displacement(p)
        verts.append(p * r[:, None])
        tris.append(quad_tris + np.uint32(f * n * n))
    return (np.concatenate(verts).astype(np.float32),
            np.concatenate(tris).astype(np.uint32))


def generate_rays(vertices, count, seed=1):
    rng = np.random.default_rng(seed)
    lo, hi = vertices.min(0), vertices.max(0)
    org = rng.uniform(lo, hi, size=(count, 3))
    d = rng.standard_normal((count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.concatenate([org, d], 1).astype(np.float32)


def cmd_generate(out, n_rays):
    os.makedirs(out, exist_ok=True)
    t0 = time.perf_counter()
    v, t = generate_mesh()
    r = generate_rays(v, n_rays)
    v.astype("<f4").tofile(os.path.join(out, "vertices.f32"))
    t.astype("<u4").tofile(os.path.join(out, "triangles.u32"))
    r.astype("<f4").tofile(os.path.join(out, "rays.f32"))
    print(f"generated {out}: vertices={len(v)} triangles={len(t)} rays={len(r)} "
          f"aabb_min={v.min(0).round(4).tolist()} aabb_max={v.max(0).round(4).tolist()} "
          f"({time.perf_counter() - t0:.1f} s)")


# --------------------------------------------------------------------------
# benchmark
# --------------------------------------------------------------------------

def load(data):
    v = np.fromfile(os.path.join(data, "vertices.f32"), dtype="<f4").reshape(-1, 3)
    t = np.fromfile(os.path.join(data, "triangles.u32"), dtype="<u4").reshape(-1, 3)
    r = np.fromfile(os.path.join(data, "rays.f32"), dtype="<f4").reshape(-1, 6)
    org = np.ascontiguousarray(r[:, :3], dtype=np.float32)
    dirs = np.ascontiguousarray(r[:, 3:], dtype=np.float32)
    return np.ascontiguousarray(v, np.float32), np.ascontiguousarray(t, np.int32), org, dirs


def run_batch(scene, org, dirs, query, threads):
    """Run one query over all rays with `threads` Python threads; returns (result, wall, cpu)."""
    n = len(org)
    bounds = np.linspace(0, n, threads + 1).astype(int)
    parts = [None] * threads

    def work(k):
        a, b = bounds[k], bounds[k + 1]
        parts[k] = scene.run(org[a:b], dirs[a:b], query=query)

    c0, t0 = time.process_time(), time.perf_counter()
    if threads == 1:
        work(0)
    else:
        ths = [threading.Thread(target=work, args=(k,)) for k in range(threads)]
        for th in ths:
            th.start()
        for th in ths:
            th.join()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return np.concatenate(parts), wall, cpu


def check_busy(what, wall, cpu, threads):
    """Warn when the process got less CPU than it asked for (machine shared with a compile?)."""
    if cpu < 0.85 * threads * wall:
        print(f"WARNING: {what}: cpu_s/wall_s = {cpu / wall:.2f} < {threads} threads; "
              f"the machine is probably busy, figures are not reliable", file=sys.stderr)


def cmd_bench(args):
    if args.threads == 1 and hasattr(os, "sched_setaffinity"):
        # Before embreex (and its TBB pool) is imported: makes the build 1-threaded too.
        cpu0 = sorted(os.sched_getaffinity(0))[0]
        os.sched_setaffinity(0, {cpu0})
    from embreex import rtcore_scene, mesh_construction

    v, t, org, dirs = load(args.data)
    n = len(org)
    print(f"data {args.data}: vertices={len(v)} triangles={len(t)} rays={n}")

    # Build --repeat times (fresh scene each) and keep the best; the last scene is used.
    best = None
    for _ in range(args.repeat):
        scene = None
        scene = rtcore_scene.EmbreeScene()
        t0, c0 = time.perf_counter(), time.process_time()
        mesh_construction.TriangleMesh(scene, v, t)   # copies vertex/index buffers
        t1 = time.perf_counter()
        # embreex commits (builds the BVH) lazily on the first run(); trigger it with one ray.
        scene.run(org[:1], dirs[:1], query="DISTANCE")
        t2, c2 = time.perf_counter(), time.process_time()
        if best is None or t2 - t0 < best[0]:
            best = (t2 - t0, t1 - t0, t2 - t1, c2 - c0)
    total, upload, commit, cpu = best
    print(f"embree build threads={args.threads} build_s={total:.3f} (upload_s={upload:.3f} "
          f"commit_s={commit:.3f}) cpu_s={cpu:.3f} triangles={len(t)}")

    # closest hit: DISTANCE returns tfar per ray (1e37 = miss), typed fast path
    best = None
    for _ in range(args.repeat):
        dist, wall, cpu = run_batch(scene, org, dirs, "DISTANCE", args.threads)
        if best is None or wall < best[0]:
            best = (wall, cpu)
    wall, cpu = best
    check_busy("closest", wall, cpu, args.threads)
    print(f"embree closest threads={args.threads} mrays_per_s={n / wall / 1e6:.3f} "
          f"wall_s={wall:.3f} cpu_s={cpu:.3f} rays={n}")

    best = None
    for _ in range(args.repeat):
        occ, wall, cpu = run_batch(scene, org, dirs, "OCCLUDED", args.threads)
        if best is None or wall < best[0]:
            best = (wall, cpu)
    wall, cpu = best
    check_busy("occlusion", wall, cpu, args.threads)
    print(f"embree occlusion threads={args.threads} mrays_per_s={n / wall / 1e6:.3f} "
          f"wall_s={wall:.3f} cpu_s={cpu:.3f} rays={n}")

    hit_closest = dist < 1e36
    # embreex's OCCLUDED result: 0 (occluded) / -1 (RTC_INVALID_GEOMETRY_ID, unoccluded)
    hit_occ = occ != -1
    agree = np.mean(hit_closest == hit_occ)
    print(f"embree hit_fraction closest={hit_closest.mean():.6f} occlusion={hit_occ.mean():.6f} "
          f"agreement={agree:.6f}")
    if args.verbose:
        d = dist[hit_closest]
        print(f"closest-hit distance: mean={d.mean():.6f} min={d.min():.6g} max={d.max():.6f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=os.path.join(REPO, "target", "bench-data"),
                    help="directory with the raw files (default: <repo>/target/bench-data)")
    ap.add_argument("--threads", type=int, choices=(1, 2), default=1)
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per query (best is kept)")
    ap.add_argument("--generate", metavar="DIR", help="write test data to DIR and exit")
    ap.add_argument("--rays", type=int, default=2_000_000, help="rays for --generate")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args()
    if args.generate:
        cmd_generate(args.generate, args.rays)
    else:
        cmd_bench(args)


if __name__ == "__main__":
    sys.exit(main())
