#!/usr/bin/env python3
"""Generate scenes/meshes/tumbler.obj: a drinking glass (a thick-walled tumbler), as a closed
solid of revolution about +y with outward-facing triangles, for a dielectric material.

Usage: python3 tumbler.py > tumbler.obj   (no inputs; the geometry is the constants below)

Units are metres: outer radius 0.036 at the rim narrowing to 0.030 at the base, height 0.10,
walls 3 mm thick, a solid base 12 mm thick. The profile runs from the centre of the bottom
outwards, up the outside, over a rounded rim, down the inside and back to the axis; the polygon
is revolved in SEGMENTS steps. Vertex normals are the smooth normals of the revolved profile
(averaged over the two profile edges at a vertex, except at the creases of the base), so the
glass looks round rather than faceted.
"""
import math
import sys

SEGMENTS = 96
HEIGHT = 0.10
R_BASE, R_RIM = 0.030, 0.036
WALL = 0.003
BASE = 0.012


def profile():
    """(r, y, crease) points from the bottom centre to the inside-bottom centre."""
    pts = [(0.0, 0.0, True), (R_BASE - 0.002, 0.0, True)]
    # Rounded bottom edge.
    for k in range(1, 4):
        a = -0.5 * math.pi + 0.5 * math.pi * k / 4
        pts.append((R_BASE - 0.002 + 0.002 * math.cos(a), 0.002 + 0.002 * math.sin(a), False))
    pts.append((R_BASE, 0.002, False))
    # Outside wall (slightly flared), in a few rings so the normals interpolate well.
    for k in range(1, 6):
        t = k / 6
        pts.append((R_BASE + (R_RIM - R_BASE) * t, 0.002 + (HEIGHT - 0.0035) * t, False))
    # Rounded rim: a half circle of diameter WALL.
    cx = R_RIM - 0.5 * WALL
    cy = HEIGHT - 0.5 * WALL
    for k in range(0, 9):
        a = math.pi * k / 8
        pts.append((cx + 0.5 * WALL * math.cos(a), cy + 0.5 * WALL * math.sin(a), False))
    # Inside wall down to the base.
    r_in_rim, r_in_base = R_RIM - WALL, R_BASE - WALL
    for k in range(1, 6):
        t = k / 6
        pts.append((r_in_rim + (r_in_base - r_in_rim) * t, cy - (cy - BASE) * t, False))
    pts.append((r_in_base, BASE, True))
    pts.append((0.0, BASE, True))
    return pts


def main():
    prof = profile()
    n = len(prof)
    # Profile-edge normals in (r, y): the profile runs counter-clockwise seen with r to the
    # right and y up... checked below through the signed volume.
    verts, norms, faces = [], [], []

    def edge_normal(i):
        (r0, y0, _), (r1, y1, _) = prof[i], prof[i + 1]
        dr, dy = r1 - r0, y1 - y0
        length = math.hypot(dr, dy)
        return (dy / length, -dr / length)  # right-hand normal of the edge direction

    # Per profile vertex, one or two normals (creases split the vertex).
    rings = []  # list of (point index, normal) per ring, in order of use by edges
    for i in range(n - 1):
        for j, end in ((i, 0), (i + 1, 1)):
            r, y, crease = prof[j]
            if crease or j == 0 or j == n - 1:
                nr, ny = edge_normal(i)
            else:
                a, b = edge_normal(j - 1), edge_normal(j)
                nr, ny = a[0] + b[0], a[1] + b[1]
                length = math.hypot(nr, ny)
                nr, ny = nr / length, ny / length
            rings.append((r, y, nr, ny))
    # Revolve each profile edge into a band of quads (two rings per edge, unshared between
    # edges so creases keep their own normals; the duplicated positions are identical).
    for e in range(n - 1):
        band = []
        for (r, y, nr, ny) in rings[2 * e: 2 * e + 2]:
            ring = []
            for k in range(SEGMENTS):
                phi = 2.0 * math.pi * k / SEGMENTS
                c, s = math.cos(phi), math.sin(phi)
                verts.append((r * c, y, r * s))
                norms.append((nr * c, ny, nr * s))
                ring.append(len(verts))
            band.append(ring)
        lo, hi = band
        for k in range(SEGMENTS):
            k1 = (k + 1) % SEGMENTS
            if prof[e][0] > 0.0:
                faces.append((lo[k], lo[k1], hi[k1]))
            if prof[e + 1][0] > 0.0:
                faces.append((lo[k], hi[k1], hi[k]))
            elif prof[e][0] > 0.0:
                pass
    # Orient outwards: positive signed volume, and normals pointing the same way.
    vol = 0.0
    for a, b, c in faces:
        pa, pb, pc = verts[a - 1], verts[b - 1], verts[c - 1]
        cr = (pb[1] * pc[2] - pb[2] * pc[1], pb[2] * pc[0] - pb[0] * pc[2], pb[0] * pc[1] - pb[1] * pc[0])
        vol += (pa[0] * cr[0] + pa[1] * cr[1] + pa[2] * cr[2]) / 6.0
    if vol < 0.0:
        faces = [(a, c, b) for a, b, c in faces]
    out = sys.stdout
    out.write("# A drinking glass (tumbler), made by scenes/meshes/tumbler.py; metres, base at y = 0.\n")
    for v in verts:
        out.write("v %.6g %.6g %.6g\n" % v)
    for v in norms:
        out.write("vn %.6g %.6g %.6g\n" % v)
    for f in faces:
        out.write("f %d//%d %d//%d %d//%d\n" % (f[0], f[0], f[1], f[1], f[2], f[2]))
    sys.stderr.write("tumbler: %d vertices, %d triangles, volume %.3g m^3\n" % (len(verts), len(faces), abs(vol)))


if __name__ == "__main__":
    main()
