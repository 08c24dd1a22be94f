"""Why Mitsuba 3's image of lajolla's simple_sphere is 0.02 % brighter than lodestar's.

A spherical emitter is sampled over the cone of directions it subtends, with density
1 / (2 pi (1 - cos_theta_max)), cos_theta_max = sqrt(1 - (r / d)^2).  For simple_sphere's light
(radius 0.1, 9-11 units from the lit sphere) 1 - cos_theta_max is about 5e-5; computed as a
difference from 1 in f32 it loses up to 1e-3 of its value, and an estimate scales with it (the
density is its inverse).  lodestar writes it as sin^2 / (1 + cos), which keeps f32's relative
accuracy.

This script asks Mitsuba itself (`scalar_rgb`, the emitter's `sample_direction`) for the
density at points of the lit hemisphere of the scene's unit sphere, and prints the
cosine-weighted mean of exact density / Mitsuba's density (f64 exact value): above 1 where
Mitsuba's estimates run bright.  Beside it, the same for lodestar's formula in f32.

    python3 benches/reference/mitsuba_sphere_cone.py     # needs `pip install mitsuba numpy`
"""
import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
c, r = np.array([0.0, 0.0, -10.0]), 0.1   # simple_sphere.xml's emitter
scene = mi.load_dict({"type": "scene", "light": {"type": "sphere", "center": c.tolist(),
                                                  "radius": r, "emitter": {"type": "area"}}})
emitter = scene.emitters()[0]
rng = np.random.default_rng(1)
ratios, lodestar, weights = [], [], []
for _ in range(20000):
    p = rng.normal(size=3)
    p /= np.linalg.norm(p)
    p[2] = -abs(p[2])                     # the hemisphere facing the light
    it = mi.SurfaceInteraction3f()
    it.p, it.n = mi.Point3f(*p), mi.Normal3f(*p)
    ds, _ = emitter.sample_direction(it, mi.Point2f(*rng.random(2)))
    d = np.linalg.norm(c - p)
    exact = 1.0 - np.sqrt(1.0 - (r / d) ** 2)
    sin2 = (np.float32(r) / np.float32(d)) ** 2
    ours = float(sin2 / (np.float32(1) + np.sqrt(np.float32(1) - sin2)))
    ratios.append(1.0 / (2.0 * np.pi * exact) / float(ds.pdf))
    lodestar.append(ours / exact)
    weights.append(max(0.0, float(np.dot((c - p) / d, p))))
w = np.array(weights)
for name, v in [("Mitsuba 3", np.array(ratios)), ("lodestar", np.array(lodestar))]:
    print(f"{name}: weighted mean of exact density / its density = {(v * w).sum() / w.sum():.6f}"
          f" (range {v.min():.6f} - {v.max():.6f})")
