#!/usr/bin/env python3
"""Whether the Markov-chain integrators converge to the reference, tile by tile.

What it measures
    For each scene and integrator, N renders of T seconds (seeds 1..N, one thread each, two
    at a time) against the scene's reference (scenes/references/SCENE.exr):
    1. the image mean over the renders relative to the reference's, with its standard error;
    2. per tile (TILE x TILE pixels, the channels averaged), z = (mean of the renders' tile
       means - the reference's) / (their standard error over the seeds). The reference's own
       noise is left out, so z overstates a difference; with N seeds z is Student-t with N - 1
       degrees of freedom when the renders converge to the reference. Reported: the largest
       |z|, the mean z^2 (about (N-1)/(N-3) in agreement, for N > 3) and the largest relative
       difference of a tile. With one seed only the image mean is reported.

Usage
    pip install mitsuba numpy          (to read EXR files)
    cargo build --profile timed
    python3 benches/reference/mcmc_convergence.py --scenes fog-dragon --integrators mmlt,pssmlt \\
        --time 240 --seeds 4 --out /tmp/conv

Renders already in --out (SCENE-INTEGRATOR-SEED.exr) are reused.
"""
import argparse
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def load(path):
    import mitsuba as mi
    import numpy as np

    mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3].mean(axis=2)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", default="fog-dragon")
    ap.add_argument("--integrators", default="mmlt,pssmlt")
    ap.add_argument("--time", type=float, default=240)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--tile", type=int, default=40)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--out", required=True)
    ap.add_argument("--lodestar", default=os.path.join(ROOT, "target/timed/lodestar"))
    args = ap.parse_args()
    import numpy as np

    os.makedirs(args.out, exist_ok=True)
    scenes = args.scenes.split(",")
    integrators = args.integrators.split(",")
    runs = []
    for s in scenes:
        for i in integrators:
            for seed in range(1, args.seeds + 1):
                exr = os.path.join(args.out, f"{s}-{i}-{seed}.exr")
                runs.append((s, i, seed, exr))

    def render(run):
        s, i, seed, exr = run
        if os.path.exists(exr):
            return
        cmd = [args.lodestar, "render", os.path.join(ROOT, "scenes", s + ".toml"), "--integrator", i,
               "--time", str(args.time), "--threads", "1", "--seed", str(seed), "-q", "-o", exr]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)

    with ThreadPoolExecutor(args.jobs) as pool:
        list(pool.map(render, runs))

    print(f"# {args.seeds} renders of {args.time:g} s per row (seeds 1-{args.seeds}), "
          f"tiles of {args.tile} px, against scenes/references/")
    print("| scene | integrator | image mean vs reference | tiles | max abs z | mean z^2 | largest tile difference |")
    print("|---|---|---|---|---|---|---|")
    t = args.tile
    for s in scenes:
        ref = load(os.path.join(ROOT, "scenes/references", s + ".exr"))
        h, w = ref.shape
        for i in integrators:
            imgs = [load(exr) for (rs, ri, _, exr) in runs if rs == s and ri == i]
            means = np.array([np.nanmean(im) for im in imgs])
            rel = means / np.nanmean(ref) - 1
            if len(imgs) < 2:
                print(f"| {s} | {i} | {100 * rel.mean():+.2f} % | | | | |")
                continue
            se = rel.std(ddof=1) / np.sqrt(len(rel))
            zs, diffs = [], []
            for y in range(0, h, t):
                for x in range(0, w, t):
                    tiles = np.array([np.nanmean(im[y:y + t, x:x + t]) for im in imgs])
                    r = np.nanmean(ref[y:y + t, x:x + t])
                    m, e = tiles.mean(), tiles.std(ddof=1) / np.sqrt(len(tiles))
                    zs.append((m - r) / e if e > 0 else 0.0)
                    diffs.append(m / r - 1 if r > 0 else 0.0)
            zs, diffs = np.array(zs), np.array(diffs)
            print(f"| {s} | {i} | {100 * rel.mean():+.2f} % +- {100 * se:.2f} % | {len(zs)} | "
                  f"{np.abs(zs).max():.2f} | {np.mean(zs ** 2):.2f} | {100 * np.abs(diffs).max():.1f} % |")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
