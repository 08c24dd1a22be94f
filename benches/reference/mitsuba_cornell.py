#!/usr/bin/env python3
"""External reference: Mitsuba 3 path-tracer throughput (samples per CPU-second).

What it measures
    Mitsuba 3 (`scalar_rgb` variant by default, or `llvm_ad_rgb` with
    --variant; `path` integrator, max_depth 8, rr_depth 5, `independent`
    sampler unless --sampler names another, box reconstruction filter, 256x256 rgb hdrfilm) rendering
    lodestar's reference Cornell box, built in Python with mi.load_dict (no
    scene files).  For each thread count and spp it prints

      mitsuba VARIANT path max_depth=8 threads=T spp=S cpu_s=X wall_s=Y
              samples_per_cpu_s=Z samples_per_s=W mean_rgb=(r,g,b)
              [mse=M rel_mse=R efficiency=E]

    (one line) where samples_per_cpu_s = 256*256*spp / CPU-seconds, CPU-seconds
    being time.process_time() (all threads of the process), and samples_per_s
    = 256*256*spp / wall-seconds.  Both clocks run around mi.render *and* the
    read-back of the image into numpy: the llvm variants return a lazy
    (unevaluated) image, so the render kernel only runs at that read-back.
    Scene loading and one untimed warm-up render per spp value (for llvm: the
    JIT compilation of the kernels, which depends on spp) are excluded.
    mean_rgb is the per-channel mean of the rendered linear image, for lodestar
    to cross-check that it renders the same picture.

    With --runs N each (threads, spp) is rendered N times (seeds seed, seed+1,
    ...); every run prints its line and a `median` line follows (the median of
    each figure over the runs).

    --mse-against REF.exr (e.g. a converged lodestar render, 256x256 RGB)
    adds mse = mean over pixels and channels of (mitsuba - ref)^2, rel_mse
    with lodestar's definition (a - r)^2 / (r^2 + 0.01), and
    efficiency = 1 / (mse * wall_s).  The reference's own noise is included in
    the MSE, so use a reference with many more samples than the measured runs.

    llvm_ad_rgb needs an LLVM shared library that Dr.Jit can use; the LLVM 14
    on Debian 12 crashes it.  Dr.Jit reads DRJIT_LIBLLVM_PATH; if that is unset
    and the variant is llvm_*, the script sets it to Debian's libllvm19
    (/usr/lib/x86_64-linux-gnu/libLLVM-19.so) when that file exists, before
    importing mitsuba.

    Thread count: Mitsuba >= 3.6 renders on Dr.Jit's nanothread pool, set with
    drjit.set_thread_count(T) (1 = no worker threads, all work on the calling
    thread). The printed cpu_s/wall_s ratio shows what was really used.

Scene (lodestar's Cornell box, y up, camera on +z looking at the origin)
    (with --ply PATH: the walls and light below around that mesh, scaled by 0.8 and
    translated by (0,-0.15,0), white diffuse, 128x128: the scene of `cargo bench --bench
    pt_batch`, whose meshes it writes)
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
    pip install mitsuba numpy    # mitsuba brings drjit; numpy is needed for llvm and --mse-against
    python3 benches/reference/mitsuba_cornell.py                      # threads 1,2 x spp 64,128
    python3 benches/reference/mitsuba_cornell.py --threads 1 --spp 64
    apt-get install libllvm19    # for llvm_ad_rgb
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so \
      python3 benches/reference/mitsuba_cornell.py --variant llvm_ad_rgb --threads 2 \
      --spp 64 128 256 --runs 3 --mse-against cornell-ref.exr --exr ''
    python3 benches/reference/mitsuba_cornell.py --preview target/mitsuba-cornell.png
    The last render at the highest spp is also written to target/mitsuba-cornell.exr
    (--exr PATH to change, --exr '' to skip).

Kernel width (llvm only)
    --llvm-target CPU:FEATURES:WIDTH sets the CPU, the LLVM feature string and the
    vector width Dr.Jit compiles its kernels for (Dr.Jit's C function
    jit_llvm_set_target, called through ctypes from libdrjit-core.so after the
    variant is set; Python has no binding for it), e.g.
      --llvm-target znver4::16          what Dr.Jit picks itself on an AVX-512 Zen 4
      --llvm-target znver4::8           AVX-512 instructions on 8-lane (256-bit) vectors
      --llvm-target znver3:+avx2,+fma:8 AVX2 only, 8 lanes
      --llvm-target znver3:+avx2,+fma:4 AVX2 only, 4 lanes
    The line printed after the variant's says what Dr.Jit then reports. Width 1 is
    refused by Dr.Jit (its packet gathers need at least 2 lanes).

Packages: mitsuba (and its dependency drjit), numpy; Debian libllvm19 for llvm.
"""

import argparse
import os
import statistics
import sys
import time

# mitsuba and drjit are imported in main(), after the arguments are parsed:
# the llvm variants need DRJIT_LIBLLVM_PATH set before the import.
dr = mi = None

VARIANTS = ("scalar_rgb", "llvm_ad_rgb")
DEBIAN_LIBLLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"
REPO = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
RES = 256


def cornell_scene(max_depth=8, ply=None, sampler="independent"):
    T = mi.ScalarTransform4f

    def diffuse(rgb, twosided=True):
        b = {"type": "diffuse", "reflectance": {"type": "rgb", "value": list(rgb)}}
        return {"type": "twosided", "bsdf": b} if twosided else b

    white = (0.73, 0.73, 0.73)
    # `rectangle` is [-1,1]^2 in the local xy plane with normal +z.
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth, "rr_depth": 5},
        "sensor": {
            "type": "perspective",
            "fov": 39.3077,
            "fov_axis": "y",
            "to_world": T().look_at(origin=[0, 0, 3.9], target=[0, 0, 0], up=[0, 1, 0]),
            "sampler": {"type": sampler, "sample_count": 64},
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
        **({} if ply is None else {"noisy_sphere": {
            # `cargo bench --bench pt_batch`'s scene: the PLY (face normals, as lodestar
            # uses for a PLY without normals) scaled by 0.8 and raised 0.15 above the centre
            "type": "ply", "filename": ply, "face_normals": True,
            "to_world": T().translate([0, -0.15, 0]).scale(0.8),
            "bsdf": diffuse(white)}}),
    }
    if ply is not None:
        return scene
    scene.update({
        "tall_box": {"type": "cube",
                     "to_world": T().translate([-0.35, -0.4, -0.3]).rotate([0, 1, 0], 18)
                                    .scale([0.3, 0.6, 0.3]),
                     "bsdf": diffuse(white)},
        "sphere": {"type": "sphere", "center": [0.4, -0.65, 0.3], "radius": 0.35,
                   "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}},
    })
    return scene


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


def to_numpy(img):
    """The image as a float64 numpy array (H, W, C); forces evaluation in llvm variants."""
    import numpy as np
    dr.eval(img)
    dr.sync_thread()
    return np.array(img, dtype=np.float64)


def read_reference(path):
    import numpy as np
    b = mi.Bitmap(path)
    a = np.array(b, dtype=np.float64)
    if a.ndim != 3 or a.shape[2] < 3:
        raise SystemExit(f"{path}: expected an RGB(A) image, got array shape {a.shape}")
    if a.shape[:2] != (RES, RES):
        raise SystemExit(f"{path}: expected {RES}x{RES}, got {a.shape[1]}x{a.shape[0]}")
    return a[:, :, :3]


def error_vs(a, ref):
    d2 = (a[:, :, :3] - ref) ** 2
    return float(d2.mean()), float((d2 / (ref * ref + 0.01)).mean())


def fmt_line(variant, max_depth, threads, spp, r, tag=""):
    line = (f"mitsuba {variant} path max_depth={max_depth} threads={threads} spp={spp}{tag} "
            f"cpu_s={r['cpu']:.3f} wall_s={r['wall']:.3f} "
            f"samples_per_cpu_s={r['sps_cpu']:.0f} samples_per_s={r['sps_wall']:.0f} "
            f"mean_rgb=({r['mean'][0]:.5f},{r['mean'][1]:.5f},{r['mean'][2]:.5f})")
    if "mse" in r:
        line += (f" mse={r['mse']:.4e} rel_mse={r['rel_mse']:.4e} "
                 f"efficiency={r['eff']:.4g}")
    return line


def measure(scene, threads, spp, seed, ref, max_depth):
    dr.set_thread_count(threads)
    c0, t0 = time.process_time(), time.perf_counter()
    img = mi.render(scene, spp=spp, seed=seed)
    if mi.variant().startswith("scalar"):
        arr = None  # already computed; converted below, outside the timing
    else:
        arr = to_numpy(img)  # the lazy llvm image is computed here
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    if arr is None:
        try:
            arr = to_numpy(img)
        except ImportError:  # pragma: no cover (numpy is optional for scalar)
            arr = None
    mean = image_mean(img) if arr is None else tuple(
        float(x) for x in arr.reshape(-1, arr.shape[-1])[:, :3].mean(0))
    if cpu < 0.85 * threads * wall:
        print(f"WARNING: cpu_s/wall_s = {cpu / wall:.2f} < {threads} threads; the machine is "
              f"probably busy (wall-clock scaling not reliable)", file=sys.stderr)
    n = RES * RES * spp
    r = {"cpu": cpu, "wall": wall, "sps_cpu": n / cpu, "sps_wall": n / wall, "mean": mean}
    if ref is not None:
        r["mse"], r["rel_mse"] = error_vs(arr, ref)
        r["eff"] = 1.0 / (r["mse"] * wall)
    print(fmt_line(mi.variant(), max_depth, threads, spp, r), flush=True)
    return img, r


def median_of(runs):
    med = {}
    for k in runs[0]:
        if k == "mean":
            med[k] = tuple(statistics.median(r[k][c] for r in runs) for c in range(3))
        else:
            med[k] = statistics.median(r[k] for r in runs)
    return med


def set_llvm_target(spec):
    """Dr.Jit's jit_llvm_set_target(cpu, features, width) from 'CPU:FEATURES:WIDTH'."""
    import ctypes
    try:
        cpu, features, width = spec.split(":")
        width = int(width)
    except ValueError:
        sys.exit(f"--llvm-target {spec!r}: expected CPU:FEATURES:WIDTH, e.g. znver3:+avx2,+fma:8")
    core = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    set_target = core._Z19jit_llvm_set_targetPKcS0_j  # jit_llvm_set_target (C++ linkage)
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    set_target(cpu.encode(), features.encode(), width)
    vector_width = core._Z21jit_llvm_vector_widthv  # jit_llvm_vector_width()
    vector_width.restype = ctypes.c_uint32
    print(f"llvm target cpu={cpu} features={features or '(the CPU default)'} "
          f"vector width now {vector_width()}", flush=True)


def main():
    global dr, mi, RES
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variant", choices=VARIANTS, default="scalar_rgb",
                    help="Mitsuba variant (default scalar_rgb)")
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--spp", type=int, nargs="+", default=[64, 128])
    ap.add_argument("--runs", type=int, default=1,
                    help="renders per (threads, spp), seeds seed..seed+runs-1; with more than "
                         "one a median line follows")
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--sampler", default="independent",
                    choices=["independent", "stratified", "multijitter", "orthogonal",
                             "ldsampler"],
                    help="Mitsuba sampler plugin (default independent; ldsampler is its "
                         "scrambled (0,2)-sequence, the peer of lodestar's pt -O sampler=sobol)")
    ap.add_argument("--seed", type=int, default=0, help="sampler seed (mi.render seed)")
    ap.add_argument("--llvm-target", metavar="CPU:FEATURES:WIDTH",
                    help="llvm variants: the CPU, feature string and vector width of Dr.Jit's "
                         "kernels (see 'Kernel width' above)")
    ap.add_argument("--mse-against", metavar="REF_EXR",
                    help="reference EXR (256x256 RGB, e.g. a converged lodestar render): "
                         "print mse, rel_mse and efficiency = 1/(mse*wall_s)")
    ap.add_argument("--exr", default=os.path.join(REPO, "target", "mitsuba-cornell.exr"),
                    help="write the last render here ('' = skip)")
    ap.add_argument("--preview", metavar="PNG", help="also write an sRGB PNG of the last render")
    ap.add_argument("--ply", metavar="PLY",
                    help="replace the tall box and the glass sphere by this mesh, as `cargo "
                         "bench --bench pt_batch` does (e.g. target/bench-data/pt-batch/"
                         "noisy-sphere-289.ply), rendered at 128x128")
    args = ap.parse_args()
    if args.llvm_target and not args.variant.startswith("llvm"):
        ap.error("--llvm-target needs an llvm variant (--variant llvm_ad_rgb)")
    if args.ply:
        RES = 128

    if args.variant.startswith("llvm") and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        if os.path.exists(DEBIAN_LIBLLVM):
            os.environ["DRJIT_LIBLLVM_PATH"] = DEBIAN_LIBLLVM
        else:
            print(f"WARNING: DRJIT_LIBLLVM_PATH unset and {DEBIAN_LIBLLVM} absent; Dr.Jit "
                  f"will search for libLLVM itself (LLVM 14 crashes it)", file=sys.stderr)
    import drjit
    import mitsuba
    dr, mi = drjit, mitsuba
    mi.set_variant(args.variant)
    if args.llvm_target:
        set_llvm_target(args.llvm_target)

    mi.set_log_level(mi.LogLevel.Warn)
    default_threads = dr.thread_count()
    llvm = os.environ.get("DRJIT_LIBLLVM_PATH") if args.variant.startswith("llvm") else None
    print(f"mitsuba {mi.__version__} drjit {dr.__version__} variant {mi.variant()} "
          f"default threads {dr.thread_count()}" + (f" libllvm {llvm}" if llvm else ""),
          flush=True)
    ref = read_reference(args.mse_against) if args.mse_against else None
    if ref is not None:
        m = ref.reshape(-1, 3).mean(0)
        print(f"reference {args.mse_against} mean_rgb=({m[0]:.5f},{m[1]:.5f},{m[2]:.5f})",
              flush=True)
    t0 = time.perf_counter()
    scene = mi.load_dict(cornell_scene(args.max_depth, args.ply, args.sampler))
    print(f"scene load {time.perf_counter() - t0:.3f} s", flush=True)

    img = None
    for threads in args.threads:
        for spp in args.spp:
            # warm-up, not timed: first-render setup costs; in llvm variants the
            # kernel compilation (the kernels depend on spp, hence one per spp)
            dr.set_thread_count(threads)
            t0 = time.perf_counter()
            if args.variant.startswith("scalar"):
                mi.render(scene, spp=4)
            else:
                to_numpy(mi.render(scene, spp=spp, seed=args.seed + 10_000))
            print(f"warm-up threads={threads} spp={spp} {time.perf_counter() - t0:.3f} s",
                  flush=True)
            runs = []
            for k in range(args.runs):
                img, r = measure(scene, threads, spp, args.seed + k, ref, args.max_depth)
                runs.append(r)
            if args.runs > 1:
                print(fmt_line(mi.variant(), args.max_depth, threads, spp, median_of(runs),
                               tag=f" median_of={args.runs}"), flush=True)

    # With 1 thread (no nanothread workers) Mitsuba's asynchronous EXR write
    # deadlocks at exit (OpenEXR waits for a worker); restore the default pool.
    dr.set_thread_count(default_threads)
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
