#!/usr/bin/env python3
"""External reference: the same Mitsuba 3 XML files rendered by Mitsuba 3 and by lodestar.

What it compares
    Every scene in scenes/mitsuba/ (or --scenes) is loaded from the same file by both
    renderers, at the resolution and spp given here (the files' `$res` and `$spp` parameters:
    `mi.load_file(path, res=..., spp=...)` and `lodestar render path -D res=... -D spp=...`).
    lodestar renders with the integrator the file names (path/volpath -> pt), or the one
    --integrator gives (bdpt, vcm, ...: the same image by other estimators).

    1. Means: N renders a side (seeds 0..N-1); per channel the mean over renders of the image
       mean, its standard error, and z = (lodestar - mitsuba) / sqrt(SE_l^2 + SE_m^2).  |z| > 4
       means the two disagree beyond Monte Carlo noise.
    2. Per region: the image cut into 8 x 8-pixel blocks; per block and channel the same z of
       the block means over renders (blocks black in half the renders or more of either
       renderer are left out and counted, with their share of the light: see row()).
       Reported: the mean of z^2 over blocks (about dof / (dof - 2), 1.07 for 16
       renders a side, when the two agree: z is Student-t distributed) and the largest |z|
       with its two-sided normal p-value times the number of blocks and channels
       (Bonferroni; below 0.01 means a block differs).
    3. Per pixel: the MSE between the two N-render averages, and its noise floor, the sum over
       pixels of the per-pixel variances of the two averages (estimated from the renders).
       MSE / floor near 1 means the pictures agree pixel by pixel; a bias b per pixel adds b^2.
       The sums are dominated by the brightest 1 % of pixels (caustics, the light's
       surroundings), whose variance estimates from a few renders are heavy-tailed: the ratio
       scatters well above 1 without any bias (see --control); the block test is the check.
    4. Time: median wall seconds per render (Mitsuba: up to reading the image back).
    --control adds a row per scene comparing lodestar with itself (seeds 0..N-1 against
    N..2N-1) by the same statistics: what agreement looks like for these sample sizes.

Usage
    pip install mitsuba numpy; apt-get install libllvm19   (for llvm_ad_rgb)
    cargo build --profile timed
    python3 benches/reference/mitsuba_xml.py --variant llvm_ad_rgb --res 128 --spp 64 --renders 8
    python3 benches/reference/mitsuba_xml.py --variant scalar_rgb --renders 16 --control \
        --scenes scenes/public/bitterli-cornell-box/scene_v3.xml --define resx=64 --define resy=64 --define spp=64
    # lajolla's Mitsuba 0.4 files as published (no parameters: the file's resolution, the spp
    # given here); Mitsuba's copy spells <lookAt> as Mitsuba 3 reads it and uses its
    # independent sampler (its ldsampler's renders are not unbiased from seed to seed:
    # docs/results.md)
    python3 benches/reference/mitsuba_xml.py --variant scalar_rgb --renders 16 --control \
        --scenes scenes/public/lajolla/cbox/cbox.xml --define none --render-spp 4 \
        --mitsuba-replace lookAt=lookat --mitsuba-replace ldsampler=independent \
        --mitsuba-replace '<integer name="dimension" value="1"/>='
"""
import argparse
import glob
import math
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def load_for_mitsuba(mi, path, defines, replacements):
    """`mi.load_file(path, **defines)`, on a copy with `OLD=NEW` replacements applied if any."""
    if not replacements:
        return mi.load_file(path, **defines)
    text = open(path).read()
    for r in replacements:
        old, new = r.rsplit("=", 1)
        text = text.replace(old, new)
    fd, copy = tempfile.mkstemp(suffix=".xml", prefix=".mitsuba-copy-", dir=os.path.dirname(os.path.abspath(path)))
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        return mi.load_file(copy, **defines)
    finally:
        os.remove(copy)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="*", default=sorted(glob.glob(os.path.join(ROOT, "scenes/mitsuba/*.xml"))))
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--res", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--renders", type=int, default=8)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--lodestar", default=os.path.join(ROOT, "target/timed/lodestar"))
    ap.add_argument("--control", action="store_true", help="also compare lodestar with itself")
    ap.add_argument("--integrator", default=None,
                    help="lodestar's integrator instead of the one the file names (e.g. bdpt, "
                         "vcm: Mitsuba's path against lodestar's other estimators)")
    ap.add_argument("--define", action="append", default=None, metavar="NAME=VALUE",
                    help="scene parameters to set instead of res and spp (repeatable; for scenes "
                         "with other parameters or none: --define none)")
    ap.add_argument("--render-spp", type=int, default=None, metavar="N",
                    help="samples per pixel for both renderers instead of the file's (Mitsuba: "
                         "mi.render(..., spp=N); lodestar: --spp N), for files without an spp "
                         "parameter")
    ap.add_argument("--mitsuba-replace", action="append", default=[], metavar="OLD=NEW",
                    help="text replaced in Mitsuba's copy of every file only (repeatable): for "
                         "files lodestar loads as published but Mitsuba 3 refuses, e.g. "
                         "lookAt=lookat (Mitsuba 3 upgrades 0.x property names, not the tag); "
                         "split at the last =, so NEW has none. "
                         "The copy is written beside the file so that relative paths resolve "
                         "and removed afterwards; lodestar always reads the file itself")
    args = ap.parse_args()

    if args.variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        os.environ["DRJIT_LIBLLVM_PATH"] = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
    import mitsuba as mi
    import numpy as np

    mi.set_variant(args.variant)
    try:
        import drjit as dr
        dr.set_thread_count(args.threads)
    except Exception:
        pass

    shown = (f"{args.res}x{args.res}, {args.spp} spp" if args.define is None
             else "parameters " + (" ".join(args.define)))
    which = f"lodestar {args.integrator}" if args.integrator else "lodestar"
    print(f"# Mitsuba {mi.__version__} {args.variant} vs {which}; {shown}, "
          f"{args.renders} renders a side, {args.threads} threads")
    print("| scene | channel means lodestar | channel means Mitsuba | max abs z (means) | 8x8 blocks: mean z^2, max abs z (Bonferroni p) | per-pixel MSE / noise floor | s/render lodestar | s/render Mitsuba |")
    print("|---|---|---|---|---|---|---|---|")
    tmp = tempfile.mkdtemp(prefix="lodestar-mitsuba-xml-")
    if args.define is None:
        defines = {"res": str(args.res), "spp": str(args.spp)}
    else:
        defines = dict(d.split("=", 1) for d in args.define if d != "none")
    for path in args.scenes:
        name = os.path.splitext(os.path.basename(path))[0]
        scene = load_for_mitsuba(mi, path, defines, args.mitsuba_replace)
        np.array(mi.render(scene, seed=999))  # warm-up (JIT compilation)
        mits, mt = [], []
        for k in range(args.renders):
            t = time.perf_counter()
            img = np.array(mi.render(scene, seed=k, spp=args.render_spp or 0), dtype=np.float64)[:, :, :3]
            mt.append(time.perf_counter() - t)
            mits.append(img)
        def lodestar(seeds):
            imgs, times = [], []
            for k in seeds:
                out = os.path.join(tmp, f"{name}-{k}.exr")
                t = time.perf_counter()
                flags = [x for k_, v in defines.items() for x in ("-D", f"{k_}={v}")]
                if args.integrator:
                    flags += ["--integrator", args.integrator]
                if args.render_spp:
                    flags += ["--spp", str(args.render_spp)]
                subprocess.run([args.lodestar, "render", path, *flags,
                                "--seed", str(k), "--threads", str(args.threads), "--quiet", "-o", out],
                               check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                times.append(time.perf_counter() - t)
                imgs.append(np.array(mi.Bitmap(out), dtype=np.float64)[:, :, :3])
            return np.stack(imgs), times

        n = args.renders
        l, lt = lodestar(range(n))
        m = np.stack(mits)

        def row(label, a, b, ta, tb):
            am, bm = a.mean(axis=(1, 2)), b.mean(axis=(1, 2))  # per render, per channel
            z = (am.mean(0) - bm.mean(0)) / np.sqrt(am.var(0, ddof=1) / n + bm.var(0, ddof=1) / n)
            mse = ((a.mean(0) - b.mean(0)) ** 2).mean()
            floor = (a.var(0, ddof=1) / n + b.var(0, ddof=1) / n).mean()
            k, h, w = 8, a.shape[1] // 8 * 8, a.shape[2] // 8 * 8
            blk = lambda x: x[:, :h, :w].reshape(n, h // k, k, w // k, k, 3).mean(axis=(2, 4))
            ab, bb = blk(a), blk(b)
            # A block of constant radiance (an environment seen directly) has no noise; the
            # two renderers' single-precision sums there differ by rounding (1e-8 of the
            # value), which must not count as a difference: the error is floored at 1e-6 of
            # the block's value.
            se = np.sqrt(ab.var(0, ddof=1) / n + bb.var(0, ddof=1) / n)
            se = np.maximum(se, 1e-6 * np.abs(bb.mean(0)))
            zb = np.where(se > 0, (ab.mean(0) - bb.mean(0)) / np.where(se > 0, se, 1), 0)
            # A block that one renderer left black in most renders has no variance estimate
            # worth a z: the far tail of a tent or Gaussian filter beside a lit edge, which
            # filter importance sampling (lodestar) reaches in few renders and splatting
            # (Mitsuba) in all, or a region one renderer never lights at all. Such blocks
            # (black in half the renders or more on either side, lit on some side) are left
            # out of the z statistics and reported with their share of the light: a share
            # near 0 is the filter's tail, a large one a real difference.
            lit = lambda x: (np.abs(x).max(axis=3) > 0).sum(axis=0)  # renders lighting a block
            sparse = (lit(ab) < n / 2) | (lit(bb) < n / 2)
            black = sparse & ((lit(ab) > 0) | (lit(bb) > 0))
            shown = ab.mean(0)[black].sum() + bb.mean(0)[black].sum()
            share = shown / max(ab.mean(0).sum() + bb.mean(0).sum(), 1e-30)
            zt = zb[~black]
            zmax = np.abs(zt).max() if zt.size else 0.0
            p = min(1.0, math.erfc(zmax / math.sqrt(2)) * zt.size)
            fmt = lambda v: " ".join(f"{x:.5f}" for x in v)
            blacks = f"; {black.sum()} mostly black ({share:.1e} of the light)" if black.any() else ""
            print(f"| {label} | {fmt(am.mean(0))} | {fmt(bm.mean(0))} | {np.abs(z).max():.2f} | "
                  f"{(zt ** 2).mean():.3f}, {zmax:.2f} (p = {p:.2g}){blacks} | "
                  f"{mse:.3e} / {floor:.3e} = {mse / floor:.3f} | {statistics.median(ta):.2f} | {tb} |")
            sys.stdout.flush()

        row(name, l, m, lt, f"{statistics.median(mt):.2f}")
        if args.control:
            l2, lt2 = lodestar(range(n, 2 * n))
            row(f"{name}: lodestar vs lodestar (control)", l, l2, lt, "")


if __name__ == "__main__":
    main()
