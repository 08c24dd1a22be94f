"""Mitsuba 3's `thindielectric`: the probability of reflection at fixed angles (found by
bisection on the lobe-choosing number of `sample`), the reference values of
`tests/chi2_bsdf.rs` (`thin_dielectric_reflects_as_mitsuba`).

    pip install mitsuba numpy
    python3 benches/reference/mitsuba_thindielectric.py
"""

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

for ior in [1.5, 1.33]:
    bsdf = mi.load_dict({"type": "thindielectric", "int_ior": ior, "ext_ior": 1.0})
    for theta in [0.0, 30.0, 60.0, 80.0, 89.0]:
        t = np.radians(theta)
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(np.sin(t), 0.0, np.cos(t))
        ctx = mi.BSDFContext()
        lo, hi = 0.0, 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            bs, _ = bsdf.sample(ctx, si, mid, mi.Point2f(0.5, 0.5))
            reflected = bs.wo[2] > 0
            lo, hi = (mid, hi) if reflected else (lo, mid)
        print(f"({ior}, {theta}, {0.5 * (lo + hi):.7f}),")
