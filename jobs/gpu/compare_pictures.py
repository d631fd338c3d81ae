#!/usr/bin/env python3
"""Compares pictures with one drawn whole: for each, the largest difference of a channel, the
pixels beyond 1 level and beyond 2, and the mean difference over the pixels that differ.
Usage: compare_pictures.py WHOLE.png OTHER.png [...]   (Debian's python3 with matplotlib)"""
import sys

import matplotlib.image as mpimg
import numpy as np


def levels(path):
    return np.rint(255 * mpimg.imread(path)).astype(int)


whole = levels(sys.argv[1])
for path in sys.argv[2:]:
    other = levels(path)
    if other.shape != whole.shape:
        sys.exit(f"{path}: {other.shape} against {whole.shape}")
    off = np.abs(other - whole).max(axis=2)
    differ = off > 0
    mean = float(np.abs(other - whole)[..., :3][differ].mean()) if differ.any() else 0.0
    print(f"{path}: largest {int(off.max())} levels; {int((off > 1).sum())} pixels beyond 1, "
          f"{int((off > 2).sum())} beyond 2, of {off.size}; {int(differ.sum())} differ, "
          f"by {mean:.2f} levels on average")
