"""Mitsuba 3's `envmap` evaluated at fixed directions: the reference values of
`tests/envmap.rs` (`envmap_radiance_matches_mitsuba`).

    pip install mitsuba numpy
    python3 benches/reference/mitsuba_envmap.py

The map is the 8 x 5 image the test builds, pixel (x, y) = (1 + x, 1 + 2 y, 0.5 + (x y mod 3))
(y = 0 the top row), seen with the identity and with a rotation of 30 degrees about
(1, 2, 3); each line is (frame, direction towards the sky, Mitsuba's radiance).
"""

import os
import tempfile

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")

W, H = 8, 5
img = np.zeros((H, W, 3), dtype=np.float32)
for y in range(H):
    for x in range(W):
        img[y, x] = (1 + x, 1 + 2 * y, 0.5 + (x * y) % 3)
path = os.path.join(tempfile.mkdtemp(), "map.exr")
mi.Bitmap(img).write(path)

directions = [
    (0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0),
    (-1.0, 0.0, 0.0), (0.3, 0.5, -0.8), (-0.6, -0.2, 0.4), (0.05, 0.99, 0.02),
    (0.7, -0.7, -0.1), (-0.2, 0.1, -0.97), (0.5, 0.5, 0.5),
]
frames = {
    "identity": mi.ScalarTransform4f(),
    # (Mitsuba does not normalise the axis.)
    "rotated": mi.ScalarTransform4f().rotate((np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0)).tolist(), 30),
}
for name, to_world in frames.items():
    emitter = mi.load_dict({"type": "envmap", "filename": path, "to_world": to_world})
    for d in directions:
        w = np.array(d, dtype=np.float64)
        w /= np.linalg.norm(w)
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(-w)
        v = emitter.eval(si)
        print(f'("{name}", [{w[0]:.7f}, {w[1]:.7f}, {w[2]:.7f}], [{v[0]:.6e}, {v[1]:.6e}, {v[2]:.6e}]),')
