"""Writes scenes/mitsuba/sky.exr: a 64 x 32 latitude-longitude sky for plastic-sky.xml, made
here (no external data): a blue-to-white gradient above the horizon, a dim brown ground
below it, and a small warm sun (about 5 degrees across) at 35 degrees elevation.

    pip install mitsuba numpy
    python3 benches/reference/make_sky.py
"""

import os

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

W, H = 64, 32
img = np.zeros((H, W, 3), dtype=np.float32)
sun = np.array([np.cos(np.radians(35)) * np.sin(2.0), np.sin(np.radians(35)), -np.cos(np.radians(35)) * np.cos(2.0)])
for y in range(H):
    theta = np.pi * y / (H - 1)
    for x in range(W):
        phi = 2 * np.pi * (x + 0.5) / W
        d = np.array([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)])
        if d[1] > 0:
            t = d[1]
            c = (1 - t) * np.array([0.9, 0.95, 1.0]) + t * np.array([0.25, 0.45, 0.9])
        else:
            c = np.array([0.12, 0.09, 0.06])
        if np.dot(d, sun) > np.cos(np.radians(5)):
            c = c + np.array([60.0, 50.0, 35.0])
        img[y, x] = c
mi.Bitmap(img).write(os.path.join(ROOT, "scenes/mitsuba/sky.exr"))
