#!/usr/bin/env python3
"""How many correct feature matches a photo collection offers, measured against
its ground truth (synthetic scenes: `<ingest>/ground_truth/` with cameras and
depth maps, docs/FORMATS.md).

For every photo and its nearest other photo by viewing direction, SIFT
features are matched (ratio test 0.8, mutual nearest neighbours, RootSIFT) and
a match counts as correct when the first photo's feature, lifted with the true
depth and reprojected with the true cameras, lands within 4 px of the second
photo's feature. Also reported: how many features are repeated in the other
photo at all (a feature within 4 px of the reprojection, visible there), and
for how many of those the descriptor's nearest neighbour is the right one.

Feature variants (OpenCV SIFT; COLMAP's extractor behaves like `grey`):
  grey       grey image, oriented SIFT
  grey_up    upright SIFT (orientation 0), lower contrast threshold
  lc_up      upright SIFT on two log-chromaticity channels (log R/G, log B/G,
             median-centred), as the sfm stage adds them
             (modules/sfm/chroma_features.h): shading and white balance cancel
  grey_lc_up both feature sets together
  lc_asift   log-chromaticity with affine simulation (OpenCV AffineFeature)

A hand-written measurement tool, not part of the pipeline: nothing in the
stack scores matches against ground truth. Needs python3-opencv and
python3-numpy (apt).

  python3 tools/match_oracle.py <workspace>/cache/ingest/<key> [variant ...]
"""
import os
import sys

os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2  # noqa: E402
import numpy as np  # noqa: E402

TOLERANCE_PX = 4.0
RATIO = 0.8
CHROMA_GAIN = 254  # chroma_features.h kChromaGain


def rotation_from_quaternion(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def read_model(folder):
    """COLMAP text model with SIMPLE_RADIAL/SIMPLE_PINHOLE cameras -> {name: (R_cam_from_world, t, (f, cx, cy, k))}."""
    cameras = {}
    for line in open(os.path.join(folder, "cameras.txt")):
        if line.startswith("#") or not line.strip():
            continue
        t = line.split()
        params = [float(v) for v in t[4:]]
        cameras[int(t[0])] = params + [0.0] * (4 - len(params))
    images = {}
    lines = [l for l in open(os.path.join(folder, "images.txt")) if not l.startswith("#")]
    for i in range(0, len(lines), 2):
        t = lines[i].split()
        if len(t) < 10:
            continue
        images[t[9]] = (rotation_from_quaternion([float(v) for v in t[1:5]]),
                        np.array([float(v) for v in t[5:8]]), cameras[int(t[8])])
    return images


def undistorted_rays(p, c):
    f, cx, cy, k = c
    u, v = (p[:, 0] - cx) / f, (p[:, 1] - cy) / f
    uu, vv = u.copy(), v.copy()
    for _ in range(10):
        s = 1 + k * (uu * uu + vv * vv)
        uu, vv = u / s, v / s
    return np.stack([uu, vv, np.ones_like(uu)], 1)


def project(x_cam, c):
    f, cx, cy, k = c
    u, v = x_cam[:, 0] / x_cam[:, 2], x_cam[:, 1] / x_cam[:, 2]
    s = 1 + k * (u * u + v * v)
    return np.stack([f * u * s + cx, f * v * s + cy], 1)


def transfer(images, depth, a, b, p):
    """Pixels p of photo a (COLMAP pixel coordinates) in photo b, and whether b sees that surface point."""
    ra, ta, ca = images[a]
    rb, tb, cb = images[b]
    h, w = depth[a].shape
    z = depth[a][np.clip(p[:, 1].astype(int), 0, h - 1), np.clip(p[:, 0].astype(int), 0, w - 1)]
    x_world = (undistorted_rays(p, ca) * z[:, None] - ta) @ ra
    x_b = x_world @ rb.T + tb
    q = project(x_b, cb)
    h, w = depth[b].shape
    inside = (z > 0) & (x_b[:, 2] > 0) & (q[:, 0] >= 0) & (q[:, 0] < w) & (q[:, 1] >= 0) & (q[:, 1] < h)
    zb = depth[b][np.clip(q[:, 1].astype(int), 0, h - 1), np.clip(q[:, 0].astype(int), 0, w - 1)]
    return q, inside & (np.abs(zb - x_b[:, 2]) < 0.02 * x_b[:, 2])


def channels(image, variant):
    parts = variant.split("_")
    out = []
    if "grey" in parts:
        out.append(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY))
    if "lc" in parts:  # as modules/sfm/chroma_features.h
        f = image.astype(np.float32) + 8
        for c in (np.log(f[..., 2] / f[..., 1]), np.log(f[..., 0] / f[..., 1])):
            out.append(np.clip(128 + CHROMA_GAIN * (c - np.median(c)), 0, 255).astype(np.uint8))
    return out


def features(image, variant):
    parts = variant.split("_")
    sift = cv2.SIFT_create(nfeatures=8192, contrastThreshold=0.04 if variant == "grey" else 0.01)
    points, descriptors = [], []
    for c in channels(image, variant):
        if "asift" in parts:
            kp, de = cv2.AffineFeature_create(sift, maxTilt=2).detectAndCompute(c, None)
        else:
            kp, de = sift.detectAndCompute(c, None)
        if de is None:
            continue
        if "up" in parts:
            unique = {(round(k.pt[0], 1), round(k.pt[1], 1), round(k.size, 1)): k for k in kp}
            kp, de = sift.compute(c, [cv2.KeyPoint(k.pt[0], k.pt[1], k.size, 0) for k in unique.values()])
        de = np.sqrt(de / (de.sum(1, keepdims=True) + 1e-9))  # RootSIFT
        points += [(k.pt[0] + 0.25, k.pt[1] + 0.25) for k in kp]  # as chroma_features.cc kColmapFromOpenCvSift
        descriptors.append(de)
    return np.array(points).reshape(-1, 2), np.vstack(descriptors).astype(np.float32)


def match(da, db):
    bf = cv2.BFMatcher(cv2.NORM_L2)
    back = {m[0].queryIdx: m[0].trainIdx for m in bf.knnMatch(db, da, k=1)}
    return np.array([(m[0].queryIdx, m[0].trainIdx) for m in bf.knnMatch(da, db, k=2)
                     if len(m) == 2 and m[0].distance < RATIO * m[1].distance
                     and back.get(m[0].trainIdx) == m[0].queryIdx]).reshape(-1, 2)


def nearest_photo(images, a):
    """The other photo whose viewing direction (camera centre seen from the scene origin) is closest to a's."""
    def direction(n):
        r, t, _ = images[n]
        centre = -r.T @ t
        return centre / np.linalg.norm(centre)
    angles = {n: np.degrees(np.arccos(np.clip(direction(a) @ direction(n), -1, 1))) for n in images if n != a}
    b = min(angles, key=angles.get)
    return b, angles[b]


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    folder = sys.argv[1]
    variants = sys.argv[2:] or ["grey", "grey_up", "lc_up", "grey_lc_up"]
    images = read_model(os.path.join(folder, "ground_truth"))
    depth = {}
    for n in images:
        d = cv2.imread(os.path.join(folder, "ground_truth", "depth", os.path.splitext(n)[0] + ".exr"),
                       cv2.IMREAD_UNCHANGED)
        if d is None:
            sys.exit(f"match_oracle: no depth map for {n} in {folder}/ground_truth/depth")
        depth[n] = d[..., 0] if d.ndim == 3 else d
    pairs = [(a,) + nearest_photo(images, a) for a in sorted(images)]
    print(f"{folder}: {len(images)} photos; nearest neighbour {np.median([p[2] for p in pairs]):.1f} deg apart "
          f"(median; max {max(p[2] for p in pairs):.1f})")
    print("variant      features  putative  correct  repeated  right-NN   (medians over each photo and its nearest)")
    for variant in variants:
        feats = {n: features(cv2.imread(os.path.join(folder, "images", n)), variant) for n in images}
        rows = []
        for a, b, _ in pairs:
            (pa, da), (pb, db) = feats[a], feats[b]
            m = match(da, db)
            q, visible = transfer(images, depth, a, b, pa)
            correct = 0
            if len(m):
                correct = int((visible[m[:, 0]] & (np.linalg.norm(q[m[:, 0]] - pb[m[:, 1]], axis=1) < TOLERANCE_PX)).sum())
            distance = np.sqrt(((q[:, None, :] - pb[None, :, :]) ** 2).sum(2))
            repeated = np.where(visible & (distance.min(1) < TOLERANCE_PX))[0]
            right = 0
            if len(repeated):
                dd = (db * db).sum(1)[None, :] - 2 * da[repeated] @ db.T  # squared distance up to a constant
                right = int((dd.argmin(1) == distance[repeated].argmin(1)).sum())
            rows.append((len(pa), len(m), correct, len(repeated), right))
        med = np.median(np.array(rows), axis=0)
        print(f"{variant:12s} {med[0]:8.0f}  {med[1]:8.0f}  {med[2]:7.0f}  {med[3]:8.0f}  {med[4]:8.0f}")


if __name__ == "__main__":
    main()
