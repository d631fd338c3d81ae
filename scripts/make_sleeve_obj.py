#!/usr/bin/env python3
"""Writes scenes/meshes/sleeve.obj: a quad mesh of a short sleeve with a flared cuff, for the
knitted mesh piece of scenes/garment.toml.

An open surface of revolution about z: 32 quads around, 16 along, from the cuff at z = 0 to the
top at z = 0.3 m. The radius is 0.06 m over the upper part and flares smoothly to 0.09 m at the
cuff over the lowest 40%. Quads are wound counter-clockwise seen from outside, so the knit's
front layer is the outside. Units are metres; the scene places it with translate. Deterministic;
no dependencies beyond the standard library.

    python3 scripts/make_sleeve_obj.py > scenes/meshes/sleeve.obj
"""
import math
import sys

AROUND, ALONG = 32, 16
LENGTH, RADIUS, CUFF_RADIUS, FLARE = 0.3, 0.06, 0.09, 0.4


def radius(z):
    s = 1 - z / (FLARE * LENGTH)  # 1 at the cuff, 0 where the flare starts
    if s <= 0:
        return RADIUS
    return RADIUS + (CUFF_RADIUS - RADIUS) * s * s * (3 - 2 * s)  # smoothstep


def main(out):
    out.write("# sleeve with a flared cuff: %d x %d quads, wound outward "
              "(scripts/make_sleeve_obj.py)\n" % (AROUND, ALONG))
    for j in range(ALONG + 1):
        z = LENGTH * j / ALONG
        r = radius(z)
        for i in range(AROUND):
            t = 2 * math.pi * i / AROUND
            out.write("v %.6f %.6f %.6f\n" % (r * math.cos(t), r * math.sin(t), z))

    def vid(i, j):
        return j * AROUND + i % AROUND + 1

    for j in range(ALONG):
        for i in range(AROUND):
            out.write("f %d %d %d %d\n" % (vid(i, j), vid(i + 1, j), vid(i + 1, j + 1),
                                           vid(i, j + 1)))


if __name__ == "__main__":
    main(sys.stdout)
