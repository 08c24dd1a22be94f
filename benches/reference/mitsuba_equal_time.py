#!/usr/bin/env python3
"""External reference: equal-time efficiency of lodestar's pt against Mitsuba 3 on the same XML files.

What it measures
    Every scene in scenes/mitsuba/ (or --scenes) is loaded unmodified from the same file by
    both renderers; parameters are set only through the files' `<default>`s, by --define
    (`mi.load_file(path, **defines)` and `lodestar render path -D name=value`; without
    --define each file's own defaults are used).  Mitsuba renders with the integrator the file
    names (path, volpath, ...), lodestar with --integrator (default pt).  Both render at the
    same --spp (both override the file's sampler: `mi.render(scene, spp=...)`, `lodestar
    render --spp ...`).

    1. Reference.  --reference FILE.exr (one per scene, in --scenes order) if given; otherwise
       Mitsuba (--ref-variant, default the --variant) renders --ref-spp samples per pixel
       (default 4096) in at least 8 passes of equal spp with seeds 1000000, 1000001, ...
       (never the seeds of the measured renders), no pass larger than 2^24 samples (the llvm
       variants trace every sample of a render at once); the reference is the mean of the
       passes.  It is cached as target/mitsuba-equal-time/<scene-stem>-ref.exr with a
       <scene-stem>-ref.json beside it recording the scene path, defines, spp and variant; a
       cached file is reused only when these match (else it is rendered again and replaced).
       The reference is a Mitsuba image, never a mixture of the two renderers: mixing would
       average two possibly different biases into the yardstick.  The passes also give the
       reference's own noise: the mean over pixels and channels of the per-pixel variance of
       the pass mean ("ref floor"), which every MSE below contains on top of the render's own
       error (the reference is independent of the renders).
    2. Renders.  --renders R (default 5) renders a renderer at --spp (default 64), seeds
       0..R-1, interleaved (Mitsuba k, lodestar k, Mitsuba k+1, ...) so that a change in the
       machine's load hits both alike.  Times are wall seconds per render:
         lodestar: the whole `lodestar render` process (scene loading, BVH build, rendering,
                   writing the EXR): what a user waits for.  One untimed 1-spp run first
                   (file caches, and a check that the scene loads).  For information the
                   table also gives the rendering seconds lodestar reports itself ("N spp in
                   X s" on stderr): the difference is loading and writing, which dominates
                   small renders of scenes with large textures or environment maps.
         Mitsuba:  the scene is loaded once, outside the timer; a render is
                   `mi.render(scene, seed=s, spp=spp)` up to the numpy read-back of the image
                   (the llvm variants evaluate lazily: the kernel runs at the read-back).  The
                   first render of an llvm variant JIT-compiles its kernels (cached on disk by
                   Dr.Jit afterwards): one untimed warm-up render at the same spp precedes the
                   timed ones.
       Per render: MSE against the reference over all pixels and the R, G, B channels (no
       crop), and CPU seconds / wall seconds (lodestar: the child's rusage; Mitsuba: the
       process's CPU time, all threads); a value well below --threads means the machine was
       busy.
    3. Per scene, one markdown table row on stdout: median seconds per render, mean MSE,
       efficiency = 1 / (mean MSE x median seconds) per renderer and the ratio lodestar /
       Mitsuba (above 1: lodestar reaches a given error sooner).  With a known ref floor also
       the ratio with the floor subtracted from both MSEs (the floor adds the same amount to
       both and pulls the plain ratio towards 1).
       Bias check: per channel, the mean over the R renders of each renderer's image mean,
       and the reference's image mean.  Welch's t of lodestar against Mitsuba (standard errors
       from the R renders; Student t with Welch-Satterthwaite degrees of freedom; p times 3
       channels, Bonferroni), and of each renderer against the reference (the reference's
       standard error from its passes).  p < 0.01 prints a WARNING (stderr at once, and after
       the table): if the two renderers' means differ beyond noise, an MSE contains a bias and
       the efficiency comparison is meaningless.  With R = 5 the test only sees biases of a
       few standard errors of a 5-render mean; use more renders to look closer
       (benches/reference/mitsuba_xml.py tests per region).

    Pixel filters: the MSE is per pixel, so it depends on how a renderer reconstructs pixels
    as well as on its path tracer.  For a tent or Gaussian <rfilter> Mitsuba splats each
    sample into every pixel the filter covers (neighbouring pixels share samples: less
    per-pixel noise, correlated between pixels), lodestar samples the filter (src/filter.rs:
    each sample counts for one pixel) unless --film splatted (lodestar's --film: Mitsuba's
    way).  Both estimate the same image, but without --film splatted the ratio on such a
    scene (e.g. the Bitterli box, tent) includes that difference; the box filter (the
    scenes/mitsuba files) compares the path tracers alone.

    Threads: lodestar --threads T; Mitsuba drjit.set_thread_count(T) (Dr.Jit 1.5: T threads in
    all, the Python thread counting as one; it is the nanothread pool on which Mitsuba >= 3.6
    renders in both the llvm and the scalar variants).

    Memory: Mitsuba's llvm variants trace all spp x pixels samples of a timed render at once
    (unless the file's integrator sets samples_per_pass); at a file's full resolution (the
    Bitterli box defaults to 1024 x 1024) 64 spp needs several GiB: set the resolution by
    --define.

Scene parameters (their <default> names)
    scenes/mitsuba/*.xml: res (square image), spp, max_depth.
    scenes/public/bitterli-cornell-box/scene_v3.xml: resx, resy (1024), spp, max_depth (65),
      integrator (path).
    scenes/public/okapi-cornell-spheres/scene.xml: none (--define none or omit --define).

Usage
    pip install mitsuba numpy; apt-get install libllvm19   (for llvm_ad_rgb; the script sets
      DRJIT_LIBLLVM_PATH to Debian's libLLVM-19.so when it is unset)
    cargo build --profile timed
    python3 benches/reference/mitsuba_equal_time.py --define res=128
    python3 benches/reference/mitsuba_equal_time.py \
        --scenes scenes/public/bitterli-cornell-box/scene_v3.xml \
        --define resx=256 --define resy=256 --spp 64 --renders 5 --ref-spp 4096 --threads 2
    python3 benches/reference/mitsuba_equal_time.py --scenes A.xml B.xml \
        --reference A-ref.exr B-ref.exr --define res=256
"""
import argparse
import atexit
import glob
import json
import math
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from mitsuba_xml import load_for_mitsuba  # noqa: E402  (Mitsuba's copy with --mitsuba-replace)
REF_SEED = 1_000_000      # reference passes: REF_SEED, REF_SEED + 1, ...
WARMUP_SEED = 2**31 - 1   # the untimed warm-up renders
MAX_PASS_SAMPLES = 2**24  # samples (pixels x spp) per reference pass


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def t_two_sided_p(t, nu):
    """Two-sided p-value of Student's t with nu (>= 1, real) degrees of freedom."""
    import numpy as np
    t = abs(t)
    if not math.isfinite(t):
        return 0.0
    if t == 0:
        return 1.0
    c = math.exp(math.lgamma((nu + 1) / 2) - math.lgamma(nu / 2)) / math.sqrt(nu * math.pi)
    # integral over x in [t, inf) of (1 + x^2/nu)^(-(nu+1)/2), with x = t / u, u in (0, 1]
    u = np.linspace(1e-9, 1.0, 20001)
    f = t / u**2 * (1 + (t / u) ** 2 / nu) ** (-(nu + 1) / 2)
    integral = float(((f[1:] + f[:-1]) / 2 * np.diff(u)).sum())
    return min(1.0, 2 * c * integral)


def welch(ma, sa, na, mb, sb, nb, floor):
    """Welch's t and p of mean ma (standard error sa, from na samples) against mb (sb, nb).

    nb = None: b's standard error is taken as known (no degrees of freedom of its own).
    floor: a lower bound on the combined standard error (exact, noise-free images)."""
    se2 = sa**2 + sb**2
    se = max(math.sqrt(se2), floor)
    t = (ma - mb) / se if se > 0 else 0.0
    den = (sa**4 / (na - 1) if na > 1 else 0) + (sb**4 / (nb - 1) if nb and nb > 1 else 0)
    nu = se2**2 / den if den > 0 else 1e6
    return t, t_two_sided_p(t, max(nu, 1.0))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", nargs="*", default=sorted(glob.glob(os.path.join(ROOT, "scenes/mitsuba/*.xml"))))
    ap.add_argument("--mitsuba-replace", action="append", default=[], metavar="OLD=NEW",
                    help="text replaced in Mitsuba's copy of every file only, as in "
                         "mitsuba_xml.py (e.g. lookAt=lookat for files lodestar loads as "
                         "published and Mitsuba 3 refuses)")
    ap.add_argument("--define", action="append", default=None, metavar="NAME=VALUE",
                    help="scene parameter for both renderers (repeatable; default: the files' own "
                         "<default>s; --define none for none)")
    ap.add_argument("--variant", default="llvm_ad_rgb", help="Mitsuba variant of the timed renders")
    ap.add_argument("--ref-variant", default=None,
                    help="Mitsuba variant of the reference (default: --variant; e.g. scalar_rgb)")
    ap.add_argument("--reference", nargs="*", default=None, metavar="EXR",
                    help="reference images, one per scene in --scenes order (instead of rendering one)")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--renders", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--lodestar", default=os.path.join(ROOT, "target/timed/lodestar"))
    ap.add_argument("--integrator", default="pt", help="lodestar's integrator")
    ap.add_argument("--film", default="sampled", choices=["sampled", "splatted"],
                    help="lodestar's --film: splatted spreads camera samples over the pixels their "
                         "filter covers, as Mitsuba's film does")
    ap.add_argument("--cache", default=os.path.join(ROOT, "target/mitsuba-equal-time"),
                    help="directory of the rendered references")
    args = ap.parse_args()
    if args.reference is not None and len(args.reference) != len(args.scenes):
        ap.error(f"--reference: {len(args.reference)} files for {len(args.scenes)} scenes")
    if args.renders < 2:
        ap.error("--renders must be at least 2 (standard errors)")
    ref_variant = args.ref_variant or args.variant

    if any(v.startswith("llvm") for v in (args.variant, ref_variant)) \
            and "DRJIT_LIBLLVM_PATH" not in os.environ:
        os.environ["DRJIT_LIBLLVM_PATH"] = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
    import mitsuba as mi
    import numpy as np
    import drjit as dr

    mi.set_variant(args.variant)
    dr.set_thread_count(args.threads)

    defines = {} if args.define is None else dict(d.split("=", 1) for d in args.define if d != "none")
    flags = [x for k, v in defines.items() for x in ("-D", f"{k}={v}")]
    shown = ("parameters " + " ".join(f"{k}={v}" for k, v in defines.items())) if defines else "the files' defaults"
    print(f"# Mitsuba {mi.__version__} {args.variant} (the file's integrator) vs lodestar "
          f"{args.integrator} (--film {args.film}); {shown}; {args.spp} spp, {args.renders} renders a side, "
          f"{args.threads} threads; efficiency = 1 / (MSE x s)")
    print("| scene | reference | s/render lodestar | s/render Mitsuba | lodestar's own render s | CPU/wall l, M | "
          "MSE lodestar | MSE Mitsuba | efficiency lodestar | efficiency Mitsuba | "
          "ratio l/M | ratio l/M, ref floor subtracted | channel means lodestar | "
          "channel means Mitsuba | channel means reference | max abs t (p x 3): l-M, l-ref, M-ref |")
    print("|" + "---|" * 16)
    sys.stdout.flush()
    tmp = tempfile.mkdtemp(prefix="lodestar-mitsuba-equal-time-")
    atexit.register(shutil.rmtree, tmp, ignore_errors=True)
    warnings = []

    def render_reference(path, stem):
        """Mitsuba reference (cached): (image, per-channel mean SE, floor, description)."""
        os.makedirs(args.cache, exist_ok=True)
        exr = os.path.join(args.cache, f"{stem}-ref.exr")
        meta_path = exr[:-4] + ".json"
        key = {"scene": os.path.abspath(path), "defines": defines, "ref_spp": args.ref_spp,
               "variant": ref_variant, "mitsuba": mi.__version__}
        if os.path.exists(exr) and os.path.exists(meta_path):
            with open(meta_path) as f:
                meta = json.load(f)
            if meta.get("key") == key:
                log(f"{stem}: reusing {exr}")
                img = np.array(mi.Bitmap(exr), dtype=np.float64)[:, :, :3]
                return img, np.array(meta["mean_se"]), meta["floor"], \
                    f"Mitsuba {ref_variant} {meta['spp']} spp (cached)"
            log(f"{stem}: {exr} was rendered with other settings ({meta.get('key')}); rendering again")
        mi.set_variant(ref_variant)
        scene = load_for_mitsuba(mi, path, defines, args.mitsuba_replace)
        w, h = (int(x) for x in scene.sensors()[0].film().crop_size())
        passes = max(8, math.ceil(args.ref_spp * w * h / MAX_PASS_SAMPLES))
        pass_spp = max(1, math.ceil(args.ref_spp / passes))
        log(f"{stem}: reference, Mitsuba {ref_variant}, {passes} passes x {pass_spp} spp at {w}x{h}")
        t0 = time.perf_counter()
        s = s2 = None
        means = []
        for i in range(passes):
            img = np.array(mi.render(scene, seed=REF_SEED + i, spp=pass_spp), dtype=np.float64)[:, :, :3]
            s = img if s is None else s + img
            s2 = img**2 if s2 is None else s2 + img**2
            means.append(img.mean(axis=(0, 1)))
        seconds = time.perf_counter() - t0
        mean = s / passes
        var_of_mean = np.maximum(s2 / passes - mean**2, 0) * passes / (passes - 1) / passes
        floor = float(var_of_mean.mean())
        mean_se = np.array(means).std(axis=0, ddof=1) / math.sqrt(passes)
        mi.Bitmap(mean.astype(np.float32)).write(exr)
        with open(meta_path, "w") as f:
            json.dump({"key": key, "spp": passes * pass_spp, "passes": passes, "floor": floor,
                       "mean_se": mean_se.tolist(), "seconds": seconds}, f, indent=1)
        log(f"{stem}: reference {passes * pass_spp} spp in {seconds:.1f} s -> {exr}")
        mi.set_variant(args.variant)
        return mean, mean_se, floor, f"Mitsuba {ref_variant} {passes * pass_spp} spp"

    for i, path in enumerate(args.scenes):
        stem = os.path.splitext(os.path.basename(path))[0]
        if args.reference is not None:
            ref = np.array(mi.Bitmap(args.reference[i]), dtype=np.float64)[:, :, :3]
            ref_se, floor, ref_desc = np.zeros(3), None, os.path.basename(args.reference[i])
        else:
            ref, ref_se, floor, ref_desc = render_reference(path, stem)
        ref_mean = ref.mean(axis=(0, 1))

        t0 = time.perf_counter()
        scene = load_for_mitsuba(mi, path, defines, args.mitsuba_replace)
        log(f"{stem}: Mitsuba loaded in {time.perf_counter() - t0:.2f} s (not timed)")
        t0 = time.perf_counter()
        warm = np.array(mi.render(scene, seed=WARMUP_SEED, spp=args.spp))
        if warm.shape[:2] != ref.shape[:2]:
            raise SystemExit(f"{stem}: image {warm.shape[1]}x{warm.shape[0]} but reference "
                             f"{ref.shape[1]}x{ref.shape[0]}")
        log(f"{stem}: Mitsuba warm-up render {time.perf_counter() - t0:.2f} s (not timed)")
        out = os.path.join(tmp, f"{stem}.exr")
        cmd = lambda spp, seed: [args.lodestar, "render", path, *flags, "--integrator", args.integrator,
                                 "--film", args.film,
                                 "--spp", str(spp), "--seed", str(seed), "--threads", str(args.threads),
                                 "--quiet", "-o", out]
        def run(c):
            r = subprocess.run(c, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if r.returncode != 0:
                raise SystemExit(f"{' '.join(c)} failed ({r.returncode}):\n{r.stderr}")
            own = re.search(r"(\d+) spp in ([0-9.]+) s", r.stderr)
            return float(own.group(2)) if own else float("nan")

        t0 = time.perf_counter()
        run(cmd(1, WARMUP_SEED))
        log(f"{stem}: lodestar 1-spp warm-up run {time.perf_counter() - t0:.2f} s (not timed)")

        res = {"l": {"t": [], "cpu": [], "mse": [], "mean": [], "own": []},
               "m": {"t": [], "cpu": [], "mse": [], "mean": []}}

        def record(r, img, wall, cpu):
            if img.shape != ref.shape:
                raise SystemExit(f"{stem}: image {img.shape[1]}x{img.shape[0]} but reference "
                                 f"{ref.shape[1]}x{ref.shape[0]}")
            r["t"].append(wall)
            r["cpu"].append(cpu / wall)
            r["mse"].append(float(((img - ref) ** 2).mean()))
            r["mean"].append(img.mean(axis=(0, 1)))

        for k in range(args.renders):
            c0, t0 = time.process_time(), time.perf_counter()
            img = np.array(mi.render(scene, seed=k, spp=args.spp))
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            record(res["m"], np.asarray(img, dtype=np.float64)[:, :, :3], wall, cpu)

            u0, t0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
            res["l"]["own"].append(run(cmd(args.spp, k)))
            wall = time.perf_counter() - t0
            u1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (u1.ru_utime - u0.ru_utime) + (u1.ru_stime - u0.ru_stime)
            record(res["l"], np.array(mi.Bitmap(out), dtype=np.float64)[:, :, :3], wall, cpu)
            log(f"{stem}: render {k}: Mitsuba {res['m']['t'][-1]:.2f} s MSE {res['m']['mse'][-1]:.3e}; "
                f"lodestar {res['l']['t'][-1]:.2f} s MSE {res['l']['mse'][-1]:.3e}")

        n = args.renders
        summary = {}
        for key, r in res.items():
            means = np.array(r["mean"])
            summary[key] = {
                "t": statistics.median(r["t"]), "cpu": statistics.median(r["cpu"]),
                "mse": statistics.fmean(r["mse"]),
                "mean": means.mean(axis=0), "se": means.std(axis=0, ddof=1) / math.sqrt(n)}
            summary[key]["eff"] = 1.0 / (summary[key]["mse"] * summary[key]["t"])
        l, m = summary["l"], summary["m"]
        ratio = l["eff"] / m["eff"]
        if floor is not None and l["mse"] > floor and m["mse"] > floor:
            ratio_floor = f"{(m['mse'] - floor) * m['t'] / ((l['mse'] - floor) * l['t']):.3f}"
            ref_desc += f", floor {floor:.2e}"
        else:
            ratio_floor = "n/a"

        # A noise-free region (an environment seen directly) makes a channel mean exact; the two
        # renderers' float sums then differ by rounding, which must not count: se >= 1e-6 x mean.
        tests = []
        for label, (ma, sa, na), (mb, sb, nb) in (
                ("lodestar vs Mitsuba", (l["mean"], l["se"], n), (m["mean"], m["se"], n)),
                ("lodestar vs reference", (l["mean"], l["se"], n), (ref_mean, ref_se, None)),
                ("Mitsuba vs reference", (m["mean"], m["se"], n), (ref_mean, ref_se, None))):
            tp = [welch(ma[c], sa[c], na, mb[c], sb[c], nb, 1e-6 * abs(mb[c])) for c in range(3)]
            c = max(range(3), key=lambda c: abs(tp[c][0]))
            t, p = tp[c][0], min(1.0, 3 * min(q for _, q in tp))
            tests.append(f"{abs(t):.2f} ({p:.2g})")
            if p < 0.01:
                w = (f"WARNING {stem}: {label}: image means differ beyond noise (channel {'RGB'[c]}: "
                     f"{ma[c]:.5f} vs {mb[c]:.5f}, t = {t:.2f}, p x 3 = {p:.2g})"
                     + ("; the efficiency comparison is meaningless" if label.startswith("lodestar vs M") else ""))
                warnings.append(w)
                log(w)
        lim = min(l["mse"], m["mse"])
        if floor is not None and floor > 0.05 * lim:
            w = (f"WARNING {stem}: the reference's own noise ({floor:.2e}) is {floor / lim:.0%} of the "
                 f"smaller MSE; raise --ref-spp")
            warnings.append(w)
            log(w)

        fmt = lambda v: " ".join(f"{x:.5f}" for x in v)
        own = statistics.median(res["l"]["own"])
        print(f"| {stem} | {ref_desc} | {l['t']:.3f} | {m['t']:.3f} | {own:.3f} | {l['cpu']:.2f}, {m['cpu']:.2f} | "
              f"{l['mse']:.4e} | {m['mse']:.4e} | {l['eff']:.4g} | {m['eff']:.4g} | {ratio:.3f} | "
              f"{ratio_floor} | {fmt(l['mean'])} | {fmt(m['mean'])} | {fmt(ref_mean)} | "
              f"{', '.join(tests)} |")
        sys.stdout.flush()

    for w in warnings:
        print(w)


if __name__ == "__main__":
    main()
