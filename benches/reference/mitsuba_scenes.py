#!/usr/bin/env python3
"""External reference: lodestar vs Mitsuba 3 on the fog and glossy Cornell boxes (image means).

What it compares
    For each scene it renders the same picture with Mitsuba 3 (`scalar_rgb`) and with lodestar
    (`pt`), both 256x256, box filter, independent sampler, max_depth 8, rr_depth 5.  The
    Mitsuba scene is the Cornell box of mitsuba_cornell.py (walls, light, camera, film) with the
    scene-specific parts read from the lodestar TOML file (so an edit of the scene file is
    followed; built-in values are used when the file does not exist):

    cornell-fog     scenes/cornell-fog.toml: walls and light, no tall box and no sphere, plus the
                    shape with an `interior` medium: a Mitsuba `cube` ([-1,1]^3, like lodestar's)
                    with the TOML transform (lodestar: scale, then rotate, then translate =
                    translate * rotate * scale), a `null` BSDF and an interior `homogeneous`
                    medium with sigma_t = sigma_a + sigma_s, albedo = sigma_s / sigma_t and an
                    isotropic phase (hg if g != 0).  As written: scale (0.6, 0.6005, 0.6),
                    rotate 25 deg about +y, translate (0, -0.3995, 0); sigma_a 0.2, sigma_s 0.8.
                    Mitsuba integrator `volpath`: like lodestar, medium scattering vertices
                    count towards max_depth and null-BSDF crossings do not (volpath.cpp).
    cornell-glossy  scenes/cornell-glossy.toml: the Cornell box with the tall box a
                    `twosided` `roughconductor` (ggx, the TOML alpha, material 'none' =
                    eta 0 + 1i, which gives a Fresnel factor of exactly 1 at every angle in
                    Mitsuba 3.9.1, specular_reflectance = the TOML constant reflectance) and the
                    sphere a `roughdielectric` (ggx, the TOML alpha, int_ior = ior, ext_ior 1).
                    Mitsuba integrator `path`.  Only a constant-reflectance conductor is mapped.

    1. Means.  N independent renders of S spp on each side (Mitsuba: mi.render(seed=k);
       lodestar: `render --seed k`), k = 0..N-1.  Prints, per channel, the mean over renders of
       the image mean, its standard error (sample std over renders / sqrt(N)), and
       z = (lodestar - mitsuba) / sqrt(SE_l^2 + SE_m^2).  |z| > 3 (or 4, given 3 channels x 2
       scenes) means the two renderers disagree beyond Monte Carlo noise.  The same is done per
       block of a 4x4 grid of 64x64-pixel blocks (row 0 = top); the largest |z| and every block
       with |z| > 4 are printed, which localises a discrepancy.  Caveat: caustic paths (the
       glossy scene) make the per-render spread heavy-tailed, so with N = 8 the SE can be
       underestimated; treat |z| of 3-4 there with caution.
    2. Images.  One render of H spp (seed 1000) on each side, written to
       target/mitsuba-<scene>.exr/.png and target/lodestar-<scene>.exr/.png, then
       `lodestar compare target/lodestar-<scene>.exr target/mitsuba-<scene>.exr`
       (Mitsuba is the reference B) prints MSE and relMSE; both include the noise of both
       images.  Also prints a z for the two H-spp image means, using the S-spp per-render
       spread scaled by S/H (meaningful only with N >= 8).  Look at the PNGs side by side.

    If lodestar cannot load a scene (e.g. a material type it does not support yet), or the scene
    file does not exist, only Mitsuba's numbers are printed for it.

    Finding (2026-11-21): scenes/cornell-fog.toml as written puts the cube's bottom face exactly
    in the floor's plane (-0.3995 - 0.6005 = -1.0; its top is at 0.201), not 1 mm below as its
    comment intends.  With that coincident null boundary lodestar's floor under the fog is about
    12% darker than with a real gap (Mitsuba's about 0.6%), and the image means disagree by 1%
    (z ~ -30).  With translate y = -0.4005 (bottom at -1.001, top at 0.2) the two agree to
    0.02% (z ~ +0.5).  Test such a variant on both sides with --scene-file.

How to run (from anywhere; paths are relative to the repository)
    pip install mitsuba numpy     # mitsuba brings drjit; EXRs are read with mi.Bitmap
    cargo build --profile timed   # the script runs ./target/timed/lodestar (no build)
    python3 benches/reference/mitsuba_scenes.py                       # both scenes, N=8, S=64, H=512
    python3 benches/reference/mitsuba_scenes.py --scenes cornell-fog --renders 8 --spp 64 --high-spp 256
    python3 benches/reference/mitsuba_scenes.py --threads 1           # while a build is running
    python3 benches/reference/mitsuba_scenes.py --high-spp 0          # means only
    python3 benches/reference/mitsuba_scenes.py --scenes cornell-fog \
        --scene-file cornell-fog=/tmp/cornell-fog-gap.toml             # a variant, both sides;
                                                  # outputs named after the file's stem

    Cost on 2 threads, per 64-spp render: Mitsuba ~11 s (fog) / ~7.5 s (glossy), lodestar
    ~9 s / ~5 s; the defaults take about 8.5 minutes for both scenes (means ~4.4 min, two
    512-spp pairs ~4.2 min).  The per-render lodestar images go to target/mitsuba-scenes/.

Packages: mitsuba (and its dependency drjit), numpy.
"""

import argparse
import math
import os
import subprocess
import sys
import time
import tomllib

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
from mitsuba_cornell import cornell_scene  # noqa: E402  (walls, light, camera, film)

T = mi.ScalarTransform4f
GRID = 4  # blocks per image side for the localised comparison


# Built-in values (the scene files as written on 2026-11-21), used when a scene file is absent.
FOG_DEFAULT = {
    "transform": {"scale": [0.6, 0.6005, 0.6], "rotate": {"axis": [0, 1, 0], "degrees": 25},
                  "translate": [0, -0.3995, 0]},
    "medium": {"sigma_a": [0.2] * 3, "sigma_s": [0.8] * 3, "g": 0.0},
}
GLOSSY_DEFAULT = {
    "conductor": {"type": "roughconductor", "alpha": 0.1, "reflectance": [0.9] * 3},
    "dielectric": {"type": "roughdielectric", "alpha": 0.05, "ior": 1.5},
}


def to_world(t):
    """lodestar's transform table: scale, then rotate, then translate = T * R * S."""
    m = T()
    if "translate" in t:
        m = m.translate(list(t["translate"]))
    if "rotate" in t:
        m = m.rotate(list(t["rotate"]["axis"]), t["rotate"]["degrees"])
    if "scale" in t:
        m = m.scale(list(t["scale"]))
    return m


def rgb(v):
    return {"type": "rgb", "value": [float(x) for x in v]}


def fog_params(desc):
    """Fog cube transform and medium from a parsed cornell-fog.toml (or the built-in values)."""
    if desc is None:
        return FOG_DEFAULT
    cube = [s for s in desc["shape"] if s.get("interior")]
    assert len(cube) == 1 and cube[0]["type"] == "cube" and "material" not in cube[0] \
        and "exterior" not in cube[0], "expected one index-matched cube with an interior medium"
    med = [m for m in desc["medium"] if m["name"] == cube[0]["interior"]][0]
    return {"transform": cube[0]["transform"], "medium": med}


def fog_scene(max_depth=8, desc=None):
    """scenes/cornell-fog.toml: walls and light, plus an index-matched cube of fog."""
    p = fog_params(desc)
    s = cornell_scene(max_depth)
    del s["tall_box"], s["sphere"]
    s["integrator"] = {"type": "volpath", "max_depth": max_depth, "rr_depth": 5}
    sa, ss = np.array(p["medium"]["sigma_a"], float), np.array(p["medium"]["sigma_s"], float)
    st = sa + ss
    g = float(p["medium"].get("g", 0.0))
    s["fog_cube"] = {
        "type": "cube",  # [-1,1]^3 like lodestar's
        "to_world": to_world(p["transform"]),
        "bsdf": {"type": "null"},
        "interior": {
            "type": "homogeneous",
            "sigma_t": rgb(st),
            "albedo": rgb(np.where(st > 0, ss / np.where(st > 0, st, 1), 0)),
            "phase": {"type": "isotropic"} if g == 0 else {"type": "hg", "g": g},
        },
    }
    return s


def glossy_params(desc):
    """Materials of the tall box and the sphere from a parsed cornell-glossy.toml."""
    if desc is None:
        return GLOSSY_DEFAULT
    mats = {m["name"]: m for m in desc["material"]}
    box = [s for s in desc["shape"] if s["type"] == "cube"]
    sph = [s for s in desc["shape"] if s["type"] == "sphere"]
    assert len(box) == 1 and len(sph) == 1, "expected one cube (tall box) and one sphere"
    c, d = mats[box[0]["material"]], mats[sph[0]["material"]]
    assert c["type"] == "roughconductor" and "reflectance" in c, \
        f"tall box: only a roughconductor with a constant 'reflectance' is mapped, got {c}"
    assert d["type"] == "roughdielectric", f"sphere: expected a roughdielectric, got {d}"
    return {"conductor": c, "dielectric": d, "box": box[0], "sphere": sph[0]}


def glossy_scene(max_depth=8, desc=None):
    """scenes/cornell-glossy.toml: the Cornell box with a rough-metal box and rough-glass sphere."""
    p = glossy_params(desc)
    c, d = p["conductor"], p["dielectric"]
    s = cornell_scene(max_depth)
    if "box" in p:
        s["tall_box"]["to_world"] = to_world(p["box"]["transform"])
        s["sphere"]["center"] = [float(x) for x in p["sphere"]["center"]]
        s["sphere"]["radius"] = float(p["sphere"]["radius"])
    s["tall_box"]["bsdf"] = {
        "type": "twosided",  # lodestar's rough conductor is two-sided
        "bsdf": {"type": "roughconductor", "distribution": "ggx", "alpha": float(c["alpha"]),
                 # eta = 0, k = 1: the Fresnel factor is exactly 1 at every angle (checked
                 # against Mitsuba 3.9.1), so the reflectance is the constant below
                 "material": "none",
                 "specular_reflectance": rgb(c["reflectance"])},
    }
    s["sphere"]["bsdf"] = {"type": "roughdielectric", "distribution": "ggx",
                           "alpha": float(d["alpha"]), "int_ior": float(d["ior"]),
                           "ext_ior": 1.0}
    return s


SCENES = {"cornell-fog": fog_scene, "cornell-glossy": glossy_scene}


def as_array(img):
    a = np.array(img, dtype=np.float64)
    return a.reshape(a.shape[0], a.shape[1], -1)[:, :, :3]


def block_means(a):
    """(GRID, GRID, 3) block means and the (3,) image mean of an (H, W, 3) image."""
    h, w, _ = a.shape
    b = a.reshape(GRID, h // GRID, GRID, w // GRID, 3).mean(axis=(1, 3))
    return b, a.mean(axis=(0, 1))


def read_exr(path):
    return as_array(mi.Bitmap(path))


def mean_se(x):
    """Mean over axis 0 and its standard error (ddof 1)."""
    x = np.asarray(x)
    return x.mean(0), x.std(0, ddof=1) / math.sqrt(x.shape[0])


def fmt3(v, f="{:.5f}"):
    return "(" + ", ".join(f.format(float(x)) for x in v) + ")"


def lodestar_render(exe, scene_file, spp, seed, out, threads, png=None):
    cmd = [exe, "render", scene_file, "--spp", str(spp), "--seed", str(seed),
           "--threads", str(threads), "-o", out]
    if png:
        cmd += ["--png", png]
    r = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(r.stderr.strip() or r.stdout.strip())
    return r.stderr.strip()


def run_scene(name, args, exe):
    print(f"\n=== {name}: N={args.renders} renders x {args.spp} spp, 256x256, max_depth 8 ===",
          flush=True)
    scene_file = args.scene_file.get(name, os.path.join("scenes", name + ".toml"))
    have_file = os.path.exists(os.path.join(REPO, scene_file))
    desc = None
    if have_file:
        with open(os.path.join(REPO, scene_file), "rb") as f:
            desc = tomllib.load(f)
    params = {"cornell-fog": fog_params, "cornell-glossy": glossy_params}[name](desc)
    print(f"Mitsuba side built from {scene_file if have_file else 'built-in values'}: "
          + "; ".join(f"{k} {v}" for k, v in params.items() if k not in ("box", "sphere")))
    scene = mi.load_dict(SCENES[name](desc=desc))
    # Output names: the scene name, or the stem of a --scene-file override.
    tag = os.path.splitext(os.path.basename(scene_file))[0] if name in args.scene_file else name
    outdir = os.path.join(REPO, "target", "mitsuba-scenes")
    os.makedirs(outdir, exist_ok=True)

    # ---- Mitsuba: N renders ----
    m_img, m_blk = [], []
    t0 = time.perf_counter()
    for k in range(args.renders):
        a = as_array(mi.render(scene, seed=k, spp=args.spp))
        b, m = block_means(a)
        m_img.append(m)
        m_blk.append(b)
    m_mean, m_se = mean_se(m_img)
    print(f"mitsuba   mean {fmt3(m_mean)} +- {fmt3(m_se, '{:.1e}')}  "
          f"({time.perf_counter() - t0:.1f} s)", flush=True)

    # ---- lodestar: N renders ----
    lodestar_ok = have_file and not args.no_lodestar
    if not have_file:
        print(f"lodestar  {scene_file} does not exist: Mitsuba only")
    l_img, l_blk = [], []
    if lodestar_ok:
        t0 = time.perf_counter()
        try:
            for k in range(args.renders):
                out = os.path.join(outdir, f"lodestar-{tag}-{args.spp}spp-{k}.exr")
                lodestar_render(exe, scene_file, args.spp, k, out, args.threads)
                b, m = block_means(read_exr(out))
                l_img.append(m)
                l_blk.append(b)
        except RuntimeError as e:
            print(f"lodestar  cannot render {scene_file}: {e}\n          Mitsuba only")
            lodestar_ok = False
    if lodestar_ok:
        l_mean, l_se = mean_se(l_img)
        print(f"lodestar  mean {fmt3(l_mean)} +- {fmt3(l_se, '{:.1e}')}  "
              f"({time.perf_counter() - t0:.1f} s)")
        z = (l_mean - m_mean) / np.sqrt(l_se ** 2 + m_se ** 2)
        rel = l_mean / m_mean - 1.0
        print(f"z (lodestar - mitsuba) {fmt3(z, '{:+.2f}')}   relative difference "
              f"{fmt3(100 * rel, '{:+.3f}')} %")
        bl, bl_se = mean_se(l_blk)
        bm, bm_se = mean_se(m_blk)
        with np.errstate(divide="ignore", invalid="ignore"):
            bz = np.where(bl_se + bm_se > 0, (bl - bm) / np.sqrt(bl_se ** 2 + bm_se ** 2), 0.0)
        i = np.unravel_index(np.argmax(np.abs(bz)), bz.shape)
        print(f"blocks ({GRID}x{GRID}, row 0 = top): max |z| = {abs(bz[i]):.2f} at row {i[0]} "
              f"col {i[1]} channel {'RGB'[i[2]]}")
        for r in range(GRID):
            for c in range(GRID):
                if np.any(np.abs(bz[r, c]) > 4):
                    print(f"  block row {r} col {c}: lodestar {fmt3(bl[r, c])} mitsuba "
                          f"{fmt3(bm[r, c])} z {fmt3(bz[r, c], '{:+.1f}')}")
        result = dict(m=(m_mean, m_se), l=(l_mean, l_se), z=z)
    else:
        result = dict(m=(m_mean, m_se))

    # ---- High-spp images ----
    if args.high_spp > 0:
        H = args.high_spp
        tgt = os.path.join(REPO, "target")
        m_exr = os.path.join(tgt, f"mitsuba-{tag}.exr")
        t0 = time.perf_counter()
        img = mi.render(scene, seed=1000, spp=H)
        mi.util.write_bitmap(m_exr, img, write_async=False)
        mi.util.write_bitmap(m_exr[:-4] + ".png", img, write_async=False)
        mm = as_array(img).mean(axis=(0, 1))
        print(f"mitsuba   {H} spp -> {os.path.relpath(m_exr, REPO)} (+ .png), mean {fmt3(mm)} "
              f"({time.perf_counter() - t0:.1f} s)", flush=True)
        if lodestar_ok:
            l_exr = os.path.join(tgt, f"lodestar-{tag}.exr")
            t0 = time.perf_counter()
            lodestar_render(exe, scene_file, H, 1000, l_exr, args.threads, png=l_exr[:-4] + ".png")
            lm = read_exr(l_exr).mean(axis=(0, 1))
            print(f"lodestar  {H} spp -> {os.path.relpath(l_exr, REPO)} (+ .png), mean {fmt3(lm)} "
                  f"({time.perf_counter() - t0:.1f} s)")
            # The per-render spread at S spp predicts the spread of one H-spp image mean.
            se1 = np.sqrt((np.std(l_img, 0, ddof=1) ** 2 + np.std(m_img, 0, ddof=1) ** 2)
                          * args.spp / H)
            print(f"z of the two {H}-spp image means {fmt3((lm - mm) / se1, '{:+.2f}')}")
            r = subprocess.run([exe, "compare", l_exr, m_exr], cwd=REPO, capture_output=True,
                               text=True)
            print(f"$ lodestar compare target/lodestar-{tag}.exr target/mitsuba-{tag}.exr")
            print((r.stdout + r.stderr).rstrip())
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    ap.add_argument("--renders", type=int, default=8, help="independent renders per side (N)")
    ap.add_argument("--spp", type=int, default=64, help="spp per render (S)")
    ap.add_argument("--high-spp", type=int, default=512,
                    help="spp of the saved comparison images (H; 0 = skip)")
    ap.add_argument("--threads", type=int, default=2, help="Mitsuba and lodestar threads")
    ap.add_argument("--lodestar", default=os.path.join(REPO, "target", "timed", "lodestar"))
    ap.add_argument("--no-lodestar", action="store_true", help="Mitsuba side only")
    ap.add_argument("--scene-file", action="append", default=[], metavar="NAME=PATH",
                    help="use PATH (relative to the repository, or absolute) for scene NAME on "
                         "both sides, e.g. cornell-fog=/tmp/fog-variant.toml")
    args = ap.parse_args()
    try:
        args.scene_file = dict(x.split("=", 1) for x in args.scene_file)
    except ValueError:
        ap.error("--scene-file takes NAME=PATH")
    for k in args.scene_file:
        if k not in SCENES:
            ap.error(f"--scene-file: unknown scene {k!r}")
    if args.renders < 2:
        ap.error("--renders must be >= 2 (the standard error needs two)")

    mi.set_log_level(mi.LogLevel.Warn)
    dr.set_thread_count(args.threads)
    print(f"mitsuba {mi.__version__} drjit {dr.__version__} variant {mi.variant()} "
          f"threads {args.threads}; lodestar {args.lodestar}")
    if not args.no_lodestar and not os.path.exists(args.lodestar):
        ap.error(f"{args.lodestar} not found: run `cargo build --profile timed` (or --no-lodestar)")
    for name in args.scenes:
        run_scene(name, args, args.lodestar)


if __name__ == "__main__":
    sys.exit(main())
