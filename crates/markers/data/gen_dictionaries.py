#!/usr/bin/env python3
"""Writes aruco_dictionaries.txt, the predefined ArUco dictionaries the `markers` crate embeds.

Run with a Python that has opencv (5.0 was used):
    ~/.cache/indoorloc-peers/bin/python crates/markers/data/gen_dictionaries.py

The bits come from OpenCV itself (cv2.aruco.getPredefinedDictionary). OpenCV's _50, _100 and
_250 sets are prefixes of the _1000 set of the same size (checked below), so each size is stored
once as a "set" and each dictionary names its set, its marker count and its own
maxCorrectionBits. A marker is one hex number: its rotation-0 bits row-major, the first cell
(top-left) in the most significant of the n*n bits (OpenCV's getBitsFromByteList order).
"""

import os

import cv2
import numpy as np

A = cv2.aruco
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "aruco_dictionaries.txt")


def bits_of(d, i):
    return A.Dictionary.getBitsFromByteList(d.bytesList[i:i + 1], d.markerSize)


def rotations_agree(d, i):
    """OpenCV stores 4 rotations; check that the crate's formula gives the same ones."""
    b = bits_of(d, i)
    n = d.markerSize
    for r in range(4):
        # the row holds 4 rotations one after the other in memory (nbytes each)
        flat = d.bytesList[i].ravel()
        nb = flat.size // 4
        one = np.zeros_like(flat)
        one[:nb] = flat[r * nb:(r + 1) * nb]
        stored = A.Dictionary.getBitsFromByteList(one.reshape(1, nb, 4), n)
        ours = b.copy()
        for _ in range(r):  # rot1[row][col] = bits[col][n-1-row]
            ours = np.array([[ours[c][n - 1 - rr] for c in range(n)] for rr in range(n)])
        if not np.array_equal(stored, ours):
            return False
    return True


def hex_of(bits):
    v = 0
    for b in bits.ravel():
        v = (v << 1) | int(b)
    n = bits.size
    return format(v, "0%dx" % ((n + 3) // 4))


def main():
    lines = [
        "# OpenCV's predefined ArUco dictionaries (DICT_4X4_50 .. DICT_7X7_1000, DICT_ARUCO_ORIGINAL).",
        "# Origin: OpenCV %s (cv2.aruco.getPredefinedDictionary), Apache-2.0 licence," % cv2.__version__,
        "# https://github.com/opencv/opencv modules/objdetect/src/aruco/predefined_dictionaries.hpp.",
        "# Written by gen_dictionaries.py in this folder; do not edit by hand.",
        "# 'set NAME SIZE COUNT' is followed by COUNT lines, one marker each: its rotation-0 bits",
        "# row-major as hex, the top-left cell in the most significant of the SIZE*SIZE bits.",
        "# 'dict NAME SET COUNT MAXCORRECTIONBITS' is a dictionary: the first COUNT markers of SET.",
    ]
    dicts = []
    for s in (4, 5, 6, 7):
        big = A.getPredefinedDictionary(getattr(A, "DICT_%dX%d_1000" % (s, s)))
        assert big.markerSize == s
        for n in (50, 100, 250, 1000):
            d = A.getPredefinedDictionary(getattr(A, "DICT_%dX%d_%d" % (s, s, n)))
            assert np.array_equal(d.bytesList, big.bytesList[:n]), "not a prefix"
            dicts.append(("%dx%d_%d" % (s, s, n), "%dx%d" % (s, s), n, d.maxCorrectionBits))
        assert all(rotations_agree(big, i) for i in range(0, 1000, 37))
        lines.append("set %dx%d %d %d" % (s, s, s, big.bytesList.shape[0]))
        lines += [hex_of(bits_of(big, i)) for i in range(big.bytesList.shape[0])]
    o = A.getPredefinedDictionary(A.DICT_ARUCO_ORIGINAL)
    assert all(rotations_agree(o, i) for i in range(0, 1024, 37))
    lines.append("set original %d %d" % (o.markerSize, o.bytesList.shape[0]))
    lines += [hex_of(bits_of(o, i)) for i in range(o.bytesList.shape[0])]
    dicts.append(("original", "original", o.bytesList.shape[0], o.maxCorrectionBits))
    lines += ["dict %s %s %d %d" % d for d in dicts]
    with open(OUT, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("wrote", OUT)


if __name__ == "__main__":
    main()
