#!/usr/bin/env python3
"""Segment ambientCG PavingStones131 (CC0) into stones vs. mossy joints.

Rerun:  venv/bin/python segment.py [path/to/PavingStones131_1K-JPG_Color.jpg]
Needs:  pillow numpy scipy scikit-image

Outputs (next to this script):
  paving131.png          cropped/resized photo (8-bit sRGB RGB PNG)
  paving131_labels.png   RGB label image, unique colour per stone, joints (0,0,0)
  paving131_overlay.png  photo with region boundaries drawn (red) for checking
  paving131_mask.png     intermediate binary stone mask (white = stone), for debugging
  paving131_side_by_side.png  overlay | labels, for quick review
"""
import os
import sys

import numpy as np
from PIL import Image
from scipy import ndimage as ndi
from skimage import color, filters, measure, morphology, segmentation

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "source", "PavingStones131_1K-JPG_Color.jpg")
NAME = "paving131"

# ---- parameters -----------------------------------------------------------
CROP = (128, 128, 896, 896)   # left, top, right, bottom in the 1024x1024 original
OUT_SIZE = 576                # resize crop (768 px) -> 576 px, Lanczos
SIGMA = 1.5                   # Gaussian smoothing of the Lab channels before computing the joint score
TOPHAT_R = 9                  # disk radius of the black top-hat on L* (local darkness = joint shadow)
B0, BS = 12.0, 12.0           # yellowness term  (b* - B0) / BS   (moss in joints is yellow-green)
D0, DS = 2.0, 8.0             # darkness term    (tophat - D0) / DS
SCORE_SIGMA = 1.5             # smoothing of the combined joint score
THRESH = None                 # score threshold; None = Otsu on the smoothed score
OPEN_R = 3                    # disk radius of the opening that cuts thin stone-stone bridges
HOLE_AREA = 400               # fill joint-coloured holes (lichen/moss spots) inside stones up to this
MIN_AREA = 60                 # stone components smaller than this are merged into mortar
MIN_INTERIOR = 300            # regions not touching the image border must be at least this big
                              # (a whole stone is ~2500 px; smaller interior bits are lichen/moss specks)
H_MAX = 2.0                   # h for h-maxima markers on the distance transform (splitting)
MERGE_T = 0.6                 # re-merge two split pieces if the mean joint score on their shared
                              # watershed line is below this (the cut ran through a stone, not a joint)
MERGE_MIN_LINE = 5            # ...and the shared line is at least this many pixels long
DIST_W = 0.03                 # weight of -distance added to the score for the watershed relief
SEED = 131                    # RNG seed for label colours

# optional overrides for experiments, e.g.  SEG_PARAMS="THRESH=0.9,H_MAX=2"
for _kv in filter(None, os.environ.get("SEG_PARAMS", "").split(",")):
    _k, _v = _kv.split("=")
    globals()[_k.strip()] = None if _v.strip() == "None" else float(_v)
OPEN_R, TOPHAT_R, MIN_AREA, HOLE_AREA, MIN_INTERIOR = (int(v) for v in (OPEN_R, TOPHAT_R, MIN_AREA, HOLE_AREA, MIN_INTERIOR))


def load_photo():
    im = Image.open(SRC).convert("RGB")
    im = im.crop(CROP).resize((OUT_SIZE, OUT_SIZE), Image.LANCZOS)
    return np.asarray(im)


def joint_score(rgb):
    lab = color.rgb2lab(rgb / 255.0)
    L = filters.gaussian(lab[..., 0], SIGMA)
    b = filters.gaussian(lab[..., 2], SIGMA)
    tophat = morphology.closing(L, morphology.disk(TOPHAT_R)) - L
    s = np.maximum((b - B0) / BS, (tophat - D0) / DS)
    return filters.gaussian(s, SCORE_SIGMA)


def stone_mask(score):
    t = filters.threshold_otsu(score) if THRESH is None else THRESH
    stone = score < t
    stone = morphology.opening(stone, morphology.disk(OPEN_R))
    stone = morphology.remove_small_holes(stone, max_size=HOLE_AREA)
    stone = morphology.remove_small_objects(stone, max_size=MIN_AREA - 1)
    return stone, t


def merge_weak_cuts(lab, stone, score):
    """Undo watershed cuts whose line is not on a joint (low mean joint score)."""
    line = stone & (lab == 0)
    pairs = {}
    pix = {}
    for y, x in zip(*np.nonzero(line)):
        nb = lab[max(0, y - 1):y + 2, max(0, x - 1):x + 2]
        s = set(nb[nb > 0].tolist())
        if len(s) == 2:
            k = tuple(sorted(s))
            pairs.setdefault(k, []).append(score[y, x])
            pix.setdefault(k, []).append((y, x))
    parent = list(range(lab.max() + 1))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    merged = []
    for k, v in pairs.items():
        if len(v) >= MERGE_MIN_LINE and float(np.mean(v)) < MERGE_T:
            a, b = find(k[0]), find(k[1])
            parent[max(a, b)] = min(a, b)
            merged.append(k)
    if not merged:
        return lab
    lut = np.array([find(i) for i in range(len(parent))])
    out = lut[lab]
    for k in merged:
        for y, x in pix[k]:
            out[y, x] = find(k[0])
    print(f"merged {len(merged)} weak watershed cut(s): {merged}")
    return out


def split_and_label(stone, score):
    # split stones that touch through a narrow neck: markers from the distance map,
    # watershed on the joint score (so cuts follow the darkest / mossiest line)
    dist = ndi.distance_transform_edt(stone)
    dist_s = filters.gaussian(dist, 1.0)
    peaks = morphology.h_maxima(dist_s, H_MAX)
    markers = measure.label(peaks & stone)
    relief = score - DIST_W * dist_s
    lab = segmentation.watershed(relief, markers, mask=stone, watershed_line=True)
    lab = merge_weak_cuts(lab, stone, score)
    # components not reached by any marker keep their own label
    rest = measure.label(stone & (lab == 0) & ~segmentation.find_boundaries(lab, mode="outer"))
    lab = np.where(rest > 0, rest + lab.max(), lab)
    # drop tiny regions (-> mortar), relabel 1..n
    out = np.zeros_like(lab)
    n = 0
    for r in measure.regionprops(lab):
        if r.area < MIN_AREA:
            continue
        # keep only the largest 4-connected piece of each region so a stone is one region
        sub = measure.label(r.image, connectivity=1)
        if sub.max() > 1:
            sizes = np.bincount(sub.ravel())[1:]
            keep = sub == (np.argmax(sizes) + 1)
        else:
            keep = r.image
        if keep.sum() < MIN_AREA:
            continue
        r0, c0, r1, c1 = r.bbox
        on_border = r0 == 0 or c0 == 0 or r1 == lab.shape[0] or c1 == lab.shape[1]
        if not on_border and keep.sum() < MIN_INTERIOR:
            continue
        n += 1
        r0, c0, r1, c1 = r.bbox
        out[r0:r1, c0:c1][keep] = n
    return out, n


def colour_labels(lab, n):
    rng = np.random.default_rng(SEED)
    cols = set()
    pal = np.zeros((n + 1, 3), np.uint8)
    i = 1
    while i <= n:
        c = tuple(int(v) for v in rng.integers(40, 256, 3))
        if c in cols:
            continue
        cols.add(c)
        pal[i] = c
        i += 1
    return pal[lab]


def main():
    rgb = load_photo()
    Image.fromarray(rgb).save(os.path.join(HERE, NAME + ".png"))
    score = joint_score(rgb)
    stone, bt = stone_mask(score)
    Image.fromarray((stone * 255).astype(np.uint8)).save(os.path.join(HERE, NAME + "_mask.png"))
    lab, n = split_and_label(stone, score)
    Image.fromarray(colour_labels(lab, n)).save(os.path.join(HERE, NAME + "_labels.png"))
    ov = rgb.copy()
    bnd = segmentation.find_boundaries(lab, mode="inner")
    ov[bnd] = (255, 0, 0)
    Image.fromarray(ov).save(os.path.join(HERE, NAME + "_overlay.png"))
    Image.fromarray(np.concatenate([ov, colour_labels(lab, n)], 1)).save(os.path.join(HERE, NAME + "_side_by_side.png"))
    mortar = float((lab == 0).mean())
    print(f"score threshold {bt:.2f}; regions {n}; mortar share {mortar:.3f}")


if __name__ == "__main__":
    main()
