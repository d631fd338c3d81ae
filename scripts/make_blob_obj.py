#!/usr/bin/env python3
"""Writes scenes/meshes/blob.obj: a closed, lumpy, bunny-sized blob for mesh-obstacle scenes.

An icosahedron subdivided three times (642 vertices, 1280 triangles, wound counter-clockwise
seen from outside), each vertex pushed along its direction by a few smooth bumps so that the
surface has hollows and saddles (not convex), and squashed in z. Unit size: scale and translate
it in the scene. Deterministic; no dependencies beyond the standard library.

    python3 scripts/make_blob_obj.py > scenes/meshes/blob.obj
"""
import math
import sys


def icosphere(levels):
    t = (1 + math.sqrt(5)) / 2
    verts = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
             (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    verts = [normalise(v) for v in verts]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(levels):
        midpoint = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in midpoint:
                pa, pb = verts[a], verts[b]
                verts.append(normalise(tuple((pa[k] + pb[k]) / 2 for k in range(3))))
                midpoint[key] = len(verts) - 1
            return midpoint[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return verts, faces


def normalise(v):
    n = math.sqrt(sum(x * x for x in v))
    return tuple(x / n for x in v)


def radius(u):
    x, y, z = u
    # Two "ears" up and forward, a hollow on one side, a gentle lump at the back.
    r = 1.0
    r += 0.25 * math.exp(-8 * ((x - 0.35) ** 2 + (y - 0.35) ** 2 + (z - 0.85) ** 2))
    r += 0.25 * math.exp(-8 * ((x - 0.35) ** 2 + (y + 0.35) ** 2 + (z - 0.85) ** 2))
    r -= 0.18 * math.exp(-6 * ((x + 0.2) ** 2 + (y - 0.95) ** 2 + z ** 2))
    r += 0.12 * math.exp(-4 * ((x + 0.9) ** 2 + y ** 2 + (z + 0.2) ** 2))
    return r


def main():
    verts, faces = icosphere(3)
    out = sys.stdout
    out.write("# blob.obj: written by scripts/make_blob_obj.py (a lumpy icosphere, unit size)\n")
    out.write(f"# {len(verts)} vertices, {len(faces)} triangles, closed, outward winding\n")
    for v in verts:
        r = radius(v)
        out.write(f"v {r * v[0]:.6f} {r * v[1]:.6f} {0.8 * r * v[2]:.6f}\n")
    for a, b, c in faces:
        out.write(f"f {a + 1} {b + 1} {c + 1}\n")


if __name__ == "__main__":
    main()
