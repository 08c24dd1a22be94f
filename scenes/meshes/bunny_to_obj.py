#!/usr/bin/env python3
"""Convert the npm package `bunny` (1.0.1) to scenes/meshes/bunny.obj.

Source and licence: the Stanford bunny from the Stanford 3D Scanning Repository
(http://graphics.stanford.edu/data/3Dscanrep/), as packaged by Mikola Lysenko in the npm
package `bunny` 1.0.1 (https://github.com/mikolalysenko/bunny), licence "Public Domain"
(package.json). The package's mesh is a closed, manifold, low-resolution reconstruction:
1839 vertices, 3674 triangles.

Usage:
    cd /tmp && npm pack bunny && tar xzf bunny-1.0.1.tgz
    python3 bunny_to_obj.py /tmp/package/index.js > bunny.obj

What it does: reads `exports.positions` and `exports.cells` (JSON arrays) from index.js,
checks the mesh is closed and manifold, centres it on the origin in x and z with its lowest
point at y = 0, scales it to height 1, orients every face outwards (positive signed volume),
and writes positions, area-weighted vertex normals and faces with 6 significant digits.
"""
import json
import math
import sys


def main(path):
    text = open(path).read()
    pos_text = text.split("exports.positions=")[1].split("exports.cells=")[0].strip().rstrip(";")
    cell_text = text.split("exports.cells=")[1].strip().rstrip(";")
    positions = json.loads(pos_text)
    cells = json.loads(cell_text)

    edges = {}
    for c in cells:
        for i in range(3):
            a, b = c[i], c[(i + 1) % 3]
            key = (min(a, b), max(a, b))
            edges[key] = edges.get(key, 0) + 1
    if any(n != 2 for n in edges.values()):
        sys.exit("the mesh is not closed and manifold")

    lo = [min(p[i] for p in positions) for i in range(3)]
    hi = [max(p[i] for p in positions) for i in range(3)]
    s = 1.0 / (hi[1] - lo[1])
    cx, cz = 0.5 * (lo[0] + hi[0]), 0.5 * (lo[2] + hi[2])
    pts = [((p[0] - cx) * s, (p[1] - lo[1]) * s, (p[2] - cz) * s) for p in positions]

    def sub(a, b):
        return (a[0] - b[0], a[1] - b[1], a[2] - b[2])

    def cross(a, b):
        return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])

    volume = 0.0
    for a, b, c in cells:
        pa, pb, pc = pts[a], pts[b], pts[c]
        volume += sum(x * y for x, y in zip(pa, cross(pb, pc))) / 6.0
    if volume < 0.0:
        cells = [[a, c, b] for a, b, c in cells]

    normals = [[0.0, 0.0, 0.0] for _ in pts]
    for a, b, c in cells:
        n = cross(sub(pts[b], pts[a]), sub(pts[c], pts[a]))
        for v in (a, b, c):
            for i in range(3):
                normals[v][i] += n[i]

    out = sys.stdout
    out.write("# The Stanford bunny (Stanford 3D Scanning Repository), from the npm package\n")
    out.write("# `bunny` 1.0.1 (public domain); made by scenes/meshes/bunny_to_obj.py.\n")
    out.write("# Height 1, base at y = 0, centred in x and z, faces outwards.\n")
    for p in pts:
        out.write("v %.6g %.6g %.6g\n" % p)
    for n in normals:
        length = math.sqrt(sum(x * x for x in n))
        out.write("vn %.6g %.6g %.6g\n" % tuple(x / length for x in n))
    for a, b, c in cells:
        out.write("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1))


if __name__ == "__main__":
    main(sys.argv[1])
