"""Mitsuba 3's `roughplastic` evaluated at fixed directions: the reference values of
`tests/chi2_microfacet.rs` (`rough_plastic_matches_mitsuba`).

    pip install mitsuba numpy
    python3 benches/reference/mitsuba_roughplastic.py

Prints one line per (distribution, alpha, theta_in, theta_out, phi_out): Mitsuba's
`eval` (the BSDF times the outgoing cosine, red channel) and `pdf`. Mitsuba's `si.wi` is
lodestar's `wo` (towards the camera), its `wo` lodestar's `wi`.
"""

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def direction(theta, phi=0.0):
    t, p = np.radians(theta), np.radians(phi)
    return mi.Vector3f(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))


for dist, alpha in [("ggx", 0.2), ("beckmann", 0.05), ("ggx", 0.5)]:
    bsdf = mi.load_dict({
        "type": "roughplastic",
        "distribution": dist,
        "alpha": alpha,
        "int_ior": 1.5,
        "ext_ior": 1.0,
        "diffuse_reflectance": {"type": "rgb", "value": [0.8, 0.4, 0.1]},
    })
    for theta_in in [0.0, 45.0, 80.0]:
        si = mi.SurfaceInteraction3f()
        si.wi = direction(theta_in)
        for theta_out, phi in [(0.0, 0.0), (30.0, 180.0), (theta_in, 180.0), (60.0, 90.0)]:
            ctx = mi.BSDFContext()
            wo = direction(theta_out, phi)
            value = bsdf.eval(ctx, si, wo)[0]
            pdf = bsdf.pdf(ctx, si, wo)
            print(f'("{dist}", {alpha}, {theta_in}, {theta_out}, {phi}, {value:.6e}, {pdf:.6e}),')
