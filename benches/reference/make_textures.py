#!/usr/bin/env python3
"""The texture test files of scenes/mitsuba/textured.xml (CC0): an 8 x 4 sRGB PNG whose texels
differ in every channel (so a flipped, mirrored or shifted lookup shows), and a unit quad as an
OBJ with texture coordinates (v up, as OBJ writes them).

    python3 benches/reference/make_textures.py scenes/mitsuba/textures
"""
import os
import struct
import sys
import zlib


def png(path, w, h, texel):
    rows = b"".join(b"\x00" + b"".join(bytes(texel(x, y)) for x in range(w)) for y in range(h))

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)))
        f.write(chunk(b"IDAT", zlib.compress(rows)))
        f.write(chunk(b"IEND", b""))


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "."
    os.makedirs(out, exist_ok=True)
    png(os.path.join(out, "grid.png"), 8, 4,
        lambda x, y: (30 + 30 * x, 230 - 60 * y, 220 if (x + y) % 2 else 40))
    with open(os.path.join(out, "quad.obj"), "w") as f:
        f.write("# a unit quad in the xy plane facing +z, with texture coordinates\n")
        f.write("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\n")
        f.write("vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n")
        f.write("vn 0 0 1\n")
        f.write("f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n")


if __name__ == "__main__":
    main()
