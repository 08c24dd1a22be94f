#!/usr/bin/env python3
"""External reference: Mitsuba 3 path-tracer throughput (samples per CPU-second).

What it measures
    Mitsuba 3 (`scalar_rgb` variant, `path` integrator, max_depth 8, rr_depth 5,
    `independent` sampler, box reconstruction filter, 256x256 rgb hdrfilm)
    rendering lodestar's reference Cornell box, built in Python with
    mi.load_dict (no scene files).  For each thread count and spp it prints

      mitsuba scalar_rgb path max_depth=8 threads=T spp=S cpu_s=X wall_s=Y
              samples_per_cpu_s=Z mean_rgb=(r,g,b)

    (one line) where samples_per_cpu_s = 256*256*spp / CPU-seconds, CPU-seconds
    being time.process_time() (all threads of the process) around mi.render
    only: scene loading and one small warm-up render are excluded.
    mean_rgb is the per-channel mean of the rendered linear image, for lodestar
    to cross-check that it renders the same picture.

    Thread count: Mitsuba >= 3.6 renders on Dr.Jit's nanothread pool, set with
    drjit.set_thread_count(T) (1 = no worker threads, all work on the calling
    thread). The printed cpu_s/wall_s ratio shows what was really used.

Scene (lodestar's Cornell box, y up, camera on +z looking at the origin)
    walls: quads of [-1,1]^3, open at z=+1; floor y=-1, ceiling y=+1, back z=-1
      white (0.73,0.73,0.73); left x=-1 red (0.65,0.05,0.05); right x=+1 green
      (0.12,0.45,0.15); all diffuse, two-sided (lodestar's diffuse is two-sided)
    light: quad at y=0.99, x in [-0.25,0.25], z in [-0.2,0.2], normal -y
      (emits downwards only), radiance (17,12,4), black diffuse BSDF
    tall box: cube [-1,1]^3 scaled (0.3,0.6,0.3), rotated 18 deg about +y
      (right-handed), translated (-0.35,-0.4,-0.3); white diffuse (two-sided
      too; irrelevant for a closed box)
    sphere: analytic, centre (0.4,-0.65,0.3), radius 0.35, smooth dielectric
      int_ior 1.5, ext_ior 1.0
    camera: perspective at (0,0,3.9) looking at the origin, up +y,
      fov 39.3077 deg on the vertical axis, 256x256

How to run
    pip install mitsuba          # brings drjit; numpy is optional (only used for the mean)
    python3 benches/reference/mitsuba_cornell.py                      # threads 1,2 x spp 64,128
    python3 benches/reference/mitsuba_cornell.py --threads 1 --spp 64
    python3 benches/reference/mitsuba_cornell.py --preview target/mitsuba-cornell.png
    The last render at the highest spp is also written to target/mitsuba-cornell.exr
    (--exr PATH to change, --exr '' to skip).

Packages: mitsuba (and its dependency drjit).
"""

import argparse
import os
import sys
import time

import drjit as dr
import mitsuba as mi

mi.set_variant("scalar_rgb")

REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
RES = 256


def cornell_scene(max_depth=8):
    T = mi.ScalarTransform4f

    def diffuse(rgb, twosided=True):
        b = {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(rgb)}}
        return {"type": "twosided", "bsdf": b} if twosided else b

    white = (0.73, 0.73, 0.73)
    # `rectangle` is [-1,1]^2 in the local xy plane with normal +z.
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth, "rr_depth": 5},
        "sensor": {
            "type": "perspective",
            "fov": 39.3077,
            "fov_axis": "y",
            "to_world": T().look_at(origin=[0, 0, 3.9], target=[0, 0, 0], up=[0, 1, 0]),
            "sampler": {"type": "independent", "sample_count": 64},
            "film": {
                "type": "hdrfilm",
                "width": RES,
                "height": RES,
                "pixel_format": "rgb",
                "component_format": "float32",
                "rfilter": {"type": "box"},
            },
        },
        # normal +y (up)
        "floor": {"type": "rectangle",
                  "to_world": T().translate([0, -1, 0]).rotate([1, 0, 0], -90),
                  "bsdf": diffuse(white)},
        # normal -y (down)
        "ceiling": {"type": "rectangle",
                    "to_world": T().translate([0, 1, 0]).rotate([1, 0, 0], 90),
                    "bsdf": diffuse(white)},
        # normal +z (towards the camera)
        "back": {"type": "rectangle",
                 "to_world": T().translate([0, 0, -1]),
                 "bsdf": diffuse(white)},
        # normal +x
        "left_red": {"type": "rectangle",
                     "to_world": T().translate([-1, 0, 0]).rotate([0, 1, 0], 90),
                     "bsdf": diffuse((0.65, 0.05, 0.05))},
        # normal -x
        "right_green": {"type": "rectangle",
                        "to_world": T().translate([1, 0, 0]).rotate([0, 1, 0], -90),
                        "bsdf": diffuse((0.12, 0.45, 0.15))},
        # rotate(x, +90) maps local +z to -y: emits downwards only.
        # scale before rotation: local x -> [-0.25,0.25], local y -> z in [-0.2,0.2]
        "light": {"type": "rectangle",
                  "to_world": T().translate([0, 0.99, 0]).rotate([1, 0, 0], 90)
                                 .scale([0.25, 0.20, 1.0]),
                  "bsdf": diffuse((0.0, 0.0, 0.0), twosided=False),
                  "emitter": {"type": "area",
                              "radiance": {"type": "rgb", "value": [17.0, 12.0, 4.0]}}},
        "tall_box": {"type": "cube",
                     "to_world": T().translate([-0.35, -0.4, -0.3]).rotate([0, 1, 0], 18)
                                    .scale([0.3, 0.6, 0.3]),
                     "bsdf": diffuse(white)},
        "sphere": {"type": "sphere", "center": [0.4, -0.65, 0.3], "radius": 0.35,
                   "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}},
    }


def image_mean(img):
    try:
        import numpy as np
        a = np.array(img, copy=False, dtype=np.float64)
        return tuple(float(x) for x in a.reshape(-1, a.shape[-1])[:, :3].mean(0))
    except ImportError:  # pragma: no cover
        b = mi.Bitmap(img)
        s = [0.0, 0.0, 0.0]
        w, h = b.size()
        for y in range(h):
            for x in range(w):
                for c in range(3):
                    s[c] += b[y][x][c]
        return tuple(v / (w * h) for v in s)


def measure(scene, threads, spp, seed=0):
    dr.set_thread_count(threads)
    c0, t0 = time.process_time(), time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    mean = image_mean(img)
    if cpu < 0.85 * threads * wall:
        print(f"WARNING: cpu_s/wall_s = {cpu / wall:.2f} < {threads} threads; the machine is "
              f"probably busy (wall-clock scaling not reliable)", file=sys.stderr)
    sps = RES * RES * spp / cpu
    print(f"mitsuba scalar_rgb path max_depth=8 threads={threads} spp={spp} "
          f"cpu_s={cpu:.3f} wall_s={wall:.3f} samples_per_cpu_s={sps:.0f} "
          f"mean_rgb=({mean[0]:.5f},{mean[1]:.5f},{mean[2]:.5f})", flush=True)
    return img


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--spp", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0, help="sampler seed (mi.render seed)")
    ap.add_argument("--exr", default=os.path.join(REPO, "target", "mitsuba-cornell.exr"),
                    help="write the last render here ('' = skip)")
    ap.add_argument("--preview", metavar="PNG", help="also write an sRGB PNG of the last render")
    args = ap.parse_args()

    mi.set_log_level(mi.LogLevel.Warn)
    print(f"mitsuba {mi.__version__} drjit {dr.__version__} variant {mi.variant()} "
          f"default threads {dr.thread_count()}", flush=True)
    t0 = time.perf_counter()
    scene = mi.load_dict(cornell_scene(args.max_depth))
    print(f"scene load {time.perf_counter() - t0:.3f} s", flush=True)

    # warm-up (first-render setup costs), not timed
    dr.set_thread_count(max(args.threads))
    mi.render(scene, spp=4)

    img = None
    for threads in args.threads:
        for spp in args.spp:
            img = measure(scene, threads, spp, args.seed)

    if args.exr:
        os.makedirs(os.path.dirname(os.path.abspath(args.exr)), exist_ok=True)
        mi.util.write_bitmap(args.exr, img)
        print(f"wrote {args.exr}")
    if args.preview:
        os.makedirs(os.path.dirname(os.path.abspath(args.preview)), exist_ok=True)
        mi.util.write_bitmap(args.preview, img)
        print(f"wrote {args.preview}")


if __name__ == "__main__":
    sys.exit(main())
