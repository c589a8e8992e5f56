#!/usr/bin/env python3
"""Makes the 1000-frame trajectory pair that the metrics reference test compares against
../shared/tools/peers/metrics.py (NumPy/SciPy). Seeded and standard-library only, so the files
are the same on every machine. See README.md in this folder for the full regeneration command.

Ground truth: a walk around a 3-D loop at 10 Hz. Estimates: the ground truth with noise, stamped
with up to 4 ms of jitter (exercises nearest-timestamp matching), where
  - frames 0, 100, 200, ... have a rotation error near 0 (1e-3 .. 1e-2 degrees),
  - frames 50, 150, 250, ... have a rotation error near 180 degrees (179.9 .. 179.999),
  - frames 7, 107, ... have a position error only (rotation exact),
  - every other frame has a few degrees and a few decimetres of noise.
"""
import math
import random

random.seed(20261124)


def qmul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def axis_angle(angle):
    v = [random.gauss(0, 1) for _ in range(3)]
    n = math.sqrt(sum(c * c for c in v))
    s = math.sin(angle / 2)
    return (math.cos(angle / 2), v[0] / n * s, v[1] / n * s, v[2] / n * s)


def line(t, p, q):
    w, x, y, z = q
    return f"{t:.6f} {p[0]!r} {p[1]!r} {p[2]!r} {x!r} {y!r} {z!r} {w!r}\n"


gt, est = [], []
for i in range(1000):
    t = 1700000000.0 + 0.1 * i
    a = 2 * math.pi * i / 1000
    p = (5 * math.cos(a), 3 * math.sin(a), 1.2 + 0.3 * math.sin(3 * a))
    q = qmul((math.cos(a / 2 + 0.4), 0.0, 0.0, math.sin(a / 2 + 0.4)), axis_angle(math.radians(10)))
    gt.append(line(t, p, q))
    if i % 100 == 0:
        dq, dp = axis_angle(math.radians(random.uniform(1e-3, 1e-2))), 0.01
    elif i % 100 == 50:
        dq, dp = axis_angle(math.radians(random.uniform(179.9, 179.999))), 0.02
    elif i % 100 == 7:
        dq, dp = (1.0, 0.0, 0.0, 0.0), 0.5
    else:
        dq, dp = axis_angle(math.radians(abs(random.gauss(0, 3)))), 0.3
    pe = tuple(c + random.gauss(0, dp) for c in p)
    est.append(line(t + random.uniform(-0.004, 0.004), pe, qmul(q, dq)))

with open("gt.tum", "w") as f:
    f.write("# timestamp tx ty tz qx qy qz qw\n")
    f.writelines(gt)
with open("est.tum", "w") as f:
    f.write("# timestamp tx ty tz qx qy qz qw\n")
    f.writelines(est)
