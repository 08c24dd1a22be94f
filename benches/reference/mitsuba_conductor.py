"""Mitsuba 3's smooth `conductor` with `eta` and `k`: its reflectance (the sample weight of the
mirror direction) at fixed angles, the reference values of `tests/chi2_bsdf.rs`
(`fresnel_conductor_reflects_as_mitsuba`).

    pip install mitsuba numpy
    python3 benches/reference/mitsuba_conductor.py
"""

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

bsdf = mi.load_dict({
    "type": "conductor",
    "eta": {"type": "rgb", "value": [0.143, 0.374, 1.442]},
    "k": {"type": "rgb", "value": [3.983, 2.385, 1.603]},
})
for theta in [0.0, 30.0, 60.0, 80.0, 89.0]:
    t = np.radians(theta)
    si = mi.SurfaceInteraction3f()
    si.wi = mi.Vector3f(np.sin(t), 0.0, np.cos(t))
    bs, w = bsdf.sample(mi.BSDFContext(), si, 0.5, mi.Point2f(0.5, 0.5))
    print(f"({theta}, [{w[0]:.7f}, {w[1]:.7f}, {w[2]:.7f}]),")
