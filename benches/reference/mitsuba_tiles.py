#!/usr/bin/env python3
"""Mitsuba 3's renders of the published scenes, reduced to tile statistics for lodestar's tests.

What it writes
    For every scene below (the published ones of `scenes/public/`, and lodestar's own
    `scenes/mitsuba/shading.xml`), `scenes/references/public/mitsuba/<name>.tiles`: a small text file
    with the mean over N independent Mitsuba renders (seeds 0..N-1) of every tile of the image
    and of the whole image, per channel, with the standard error of that mean (from the spread
    of the renders). `tests/mitsuba_tiles.rs` renders the same file with lodestar's pt, bdpt
    and vcm and tests tile by tile that the two agree within the noise of both.

    The published films are large (512 to 1024 pixels across); both renderers read the files
    with the film's width and height replaced by a size 8 times smaller (the `film` line), or
    with the file's own resolution parameters (`define`). Mitsuba's copy also gets the edits
    it needs to read lajolla's 0.4 files (`<lookAt>` spelled `<lookat>`, its `independent`
    sampler in place of `ldsampler`, whose renders are not independent from seed to seed);
    lodestar reads them as published.

File format (lines; `#` starts a comment)
    scene <path from the repository root>
    film <width> <height> <rendered width> <rendered height>     (or none: `define` sets it)
    define <name>=<value>                                         (zero or more)
    tile <pixels>          square tiles, the last row and column of the image may be smaller
    renders <N>
    spp <S>                samples per pixel of each render
    image <mean r g b> <standard error r g b>
    t <mean r g b> <standard error r g b>                         (one per tile, row-major)

Usage
    pip install mitsuba numpy; apt-get install libllvm19
    python3 benches/reference/mitsuba_tiles.py [--renders 32] [--spp-scale 1] [names...]
"""
import argparse
import os
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

LAJOLLA_EDITS = [("lookAt", "lookat"), ("ldsampler", "independent"),
                 ('<integer name="dimension" value="1"/>', "")]

# name: (file, film (w0, h0, w, h) or None, defines, Mitsuba-only edits, spp per render)
SCENES = {
    "bitterli-cornell-box": ("scenes/public/bitterli-cornell-box/scene_v3.xml", None,
                             {"resx": "128", "resy": "128"}, [], 512),
    "okapi-cornell-spheres": ("scenes/public/okapi-cornell-spheres/scene.xml",
                              (1024, 1024, 128, 128), {}, [], 512),
    "lajolla-cbox": ("scenes/public/lajolla/cbox/cbox.xml", (512, 512, 64, 64), {},
                     LAJOLLA_EDITS, 1024),
    "lajolla-veach_mi": ("scenes/public/lajolla/veach_mi/mi.xml", (768, 512, 96, 64), {},
                         LAJOLLA_EDITS, 1024),
    "lajolla-matpreview": ("scenes/public/lajolla/matpreview/matpreview.xml",
                           (683, 512, 85, 64), {}, LAJOLLA_EDITS, 1024),
    "lajolla-pixel_filter_test": ("scenes/public/lajolla/pixel_filter_test/pixel_filter_test.xml",
                                  (640, 480, 80, 60), {}, LAJOLLA_EDITS, 1024),
    "lajolla-simple_sphere": ("scenes/public/lajolla/disney_bsdf_test/simple_sphere.xml",
                              (512, 512, 64, 64), {}, LAJOLLA_EDITS, 1024),
    # lodestar's own test scene of textured shading (scenes/mitsuba/, CC0).
    "shading": ("scenes/mitsuba/shading.xml", None, {"res": "64"}, [], 1024),
    # lodestar's own test scene of anisotropic roughness (scenes/mitsuba/, CC0).
    "anisotropic": ("scenes/mitsuba/anisotropic.xml", None, {"res": "64"}, [], 1024),
    # lodestar's own test scene of blended BSDFs (scenes/mitsuba/, CC0).
    "blend": ("scenes/mitsuba/blend.xml", None, {"res": "64"}, [], 1024),
}


def film_edits(film):
    """The text edits that set the film's size (the same for both renderers)."""
    if film is None:
        return []
    w0, h0, w, h = film
    return [(f'name="width" value="{w0}"', f'name="width" value="{w}"'),
            (f'name="height" value="{h0}"', f'name="height" value="{h}"')]


def tile_size(width):
    """About eight tiles across."""
    return max(4, -(-width // 8))


def tile_means(img, t):
    """Per tile (row-major, ragged last row and column) the mean of each channel."""
    import numpy as np
    h, w, _ = img.shape
    out = []
    for y in range(0, h, t):
        for x in range(0, w, t):
            out.append(img[y:y + t, x:x + t].reshape(-1, 3).mean(axis=0))
    return np.array(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("names", nargs="*", default=list(SCENES))
    ap.add_argument("--renders", type=int, default=32)
    ap.add_argument("--spp-scale", type=float, default=1.0,
                    help="multiply every scene's spp per render (a quick trial: 0.05)")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(ROOT, "scenes/references/public/mitsuba"))
    args = ap.parse_args()

    if args.variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ:
        os.environ["DRJIT_LIBLLVM_PATH"] = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
    import mitsuba as mi
    import numpy as np
    mi.set_variant(args.variant)
    import drjit as dr
    dr.set_thread_count(args.threads)
    os.makedirs(args.out, exist_ok=True)

    for name in args.names:
        path, film, defines, edits, spp = SCENES[name]
        spp = max(1, int(spp * args.spp_scale))
        full = os.path.join(ROOT, path)
        text = open(full).read()
        for old, new in film_edits(film):
            assert old in text, f"{path}: '{old}' not found"
            text = text.replace(old, new)
        for old, new in edits:  # where the file has them
            text = text.replace(old, new)
        fd, copy = tempfile.mkstemp(suffix=".xml", prefix=".mitsuba-copy-", dir=os.path.dirname(full))
        try:
            with os.fdopen(fd, "w") as f:
                f.write(text)
            scene = mi.load_file(copy, **defines)
        finally:
            os.remove(copy)
        renders = []
        for k in range(args.renders):
            img = np.array(mi.render(scene, seed=k, spp=spp), dtype=np.float64)[:, :, :3]
            renders.append(img)
            print(f"{name}: render {k + 1}/{args.renders}", file=sys.stderr, flush=True)
        h, w, _ = renders[0].shape
        t = tile_size(w)
        n = len(renders)
        tiles = np.stack([tile_means(r, t) for r in renders])  # render, tile, channel
        means = np.stack([r.reshape(-1, 3).mean(axis=0) for r in renders])
        fmt = lambda v: " ".join(f"{x:.9g}" for x in v)
        out = os.path.join(args.out, f"{name}.tiles")
        tmp = out + ".tmp"
        with open(tmp, "w") as f:
            f.write(f"# Mitsuba {mi.__version__} {args.variant}, the file's integrator: tile means of "
                    f"{n} independent renders (seeds 0..{n - 1}), {w} x {h} pixels\n")
            f.write(f"# python3 benches/reference/mitsuba_tiles.py --renders {n} {name}\n")
            f.write(f"scene {path}\n")
            if film is not None:
                f.write("film " + " ".join(str(v) for v in film) + "\n")
            for k, v in defines.items():
                f.write(f"define {k}={v}\n")
            f.write(f"tile {t}\nrenders {n}\nspp {spp}\n")
            f.write(f"image {fmt(means.mean(0))} {fmt(means.std(0, ddof=1) / np.sqrt(n))}\n")
            for i in range(tiles.shape[1]):
                f.write(f"t {fmt(tiles[:, i].mean(0))} {fmt(tiles[:, i].std(0, ddof=1) / np.sqrt(n))}\n")
        os.replace(tmp, out)
        print(f"{name}: {w} x {h}, {tiles.shape[1]} tiles of {t} -> {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
