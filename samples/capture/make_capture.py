"""Renders `cobbles/`: a synthetic photometric capture with ground truth (Dong digest §4.2).

A periodic 96×96 height field of rounded cobbles (seeded random bumps on a torus) with a
varying albedo, rendered under 36 distant lights (slants 30°, 45°, 60° × tilts 0°…330°)
as Lambert + a Blinn highlight (k_s = 0.3, exponent 20) with attached shadows, written as
16-bit linear greyscale PNGs, plus `cobbles.lp` (the RTI light-position file: x right, y up
the image, z to the camera) and the true height and albedo as 16-bit PNGs.

Frame: x = column, y = row (down), z towards the camera; a light's tilt runs from +x to +y.
Run with Python 3, NumPy and Pillow: `python make_capture.py` (writes next to itself).
"""
import math
import os

import numpy as np
from PIL import Image

N = 96
SEED = 7
rng = np.random.default_rng(SEED)
here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "cobbles")
os.makedirs(here, exist_ok=True)

y, x = np.mgrid[0:N, 0:N].astype(np.float64)
height = np.zeros((N, N))
albedo = np.full((N, N), 0.55)
for _ in range(26):
    cx, cy = rng.uniform(0, N, 2)
    r = rng.uniform(8, 14)
    h = rng.uniform(3, 5.5)
    tone = rng.uniform(-0.15, 0.2)
    # Periodic distance on the torus, so the sample tiles and Frankot–Chellappa is exact.
    dx = (x - cx + N / 2) % N - N / 2
    dy = (y - cy + N / 2) % N - N / 2
    d2 = (dx * dx + dy * dy) / (r * r)
    bump = h * np.clip(1 - d2, 0, None) ** 1.5
    mask = bump > height
    height = np.maximum(height, bump)
    albedo = np.where(mask & (bump > 0.3), 0.55 + tone, albedo)
albedo += 0.04 * np.sin(2 * math.pi * x / N * 5) * np.cos(2 * math.pi * y / N * 3)

# Central differences on the torus.
p = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) / 2
q = (np.roll(height, -1, axis=0) - np.roll(height, 1, axis=0)) / 2
norm = np.sqrt(p * p + q * q + 1)
n = np.stack([-p / norm, -q / norm, 1 / norm])

lines = []
images = []
for slant in (30, 45, 60):
    for tilt in range(0, 360, 30):
        t, s = math.radians(tilt), math.radians(slant)
        l = np.array([math.cos(t) * math.sin(s), math.sin(t) * math.sin(s), math.cos(s)])
        ndotl = np.tensordot(l, n, axes=1)
        h = l + np.array([0, 0, 1.0])
        h /= np.linalg.norm(h)
        ndoth = np.tensordot(h, n, axes=1)
        lit = albedo * np.clip(ndotl, 0, None) + 0.3 * np.where(ndotl > 0, np.clip(ndoth, 0, None) ** 20, 0)
        name = f"cobbles_s{slant:02d}_t{tilt:03d}.png"
        images.append((name, lit))
        # The light-position file's y runs up the image.
        lines.append(f"{name} {l[0]:.6f} {-l[1]:.6f} {l[2]:.6f}")

peak = max(img.max() for _, img in images)
for name, lit in images:
    v = np.round(np.clip(lit / peak, 0, 1) * 65535).astype(np.uint16)
    Image.fromarray(v).save(os.path.join(here, name))
with open(os.path.join(here, "cobbles.lp"), "w") as f:
    f.write(f"{len(lines)}\n" + "\n".join(lines) + "\n")
hn = (height - height.min()) / (height.max() - height.min())
Image.fromarray(np.round(hn * 65535).astype(np.uint16)).save(os.path.join(here, "truth_height.png"))
Image.fromarray(np.round(np.clip(albedo, 0, 1) * 65535).astype(np.uint16)).save(os.path.join(here, "truth_albedo.png"))
print("peak", peak, "height range", height.min(), height.max())
