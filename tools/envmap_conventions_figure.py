#!/usr/bin/env python3
"""Draws docs/images/envmap_conventions.png: where the world's horizon directions +X, +Y, -X, -Y (world +Z up)
fall in a lat-long map of each convention `--envmap-convention` accepts (modules/relight/render_cameras.h).

    /usr/bin/python3 tools/envmap_conventions_figure.py docs/images/envmap_conventions.png
"""
import math
import sys

import cv2
import numpy as np

CONVENTIONS = [
    ("relight", "u = phi / 2pi", lambda phi: phi / (2 * math.pi)),
    ("blender", "u = 1/2 - phi / 2pi  (Cycles world)", lambda phi: 0.5 - phi / (2 * math.pi)),
    ("mitsuba", "u = 1/4 - phi / 2pi  (Mitsuba 3, +Y up)", lambda phi: 0.25 - phi / (2 * math.pi)),
]
AXES = [("+X", 0.0, (40, 40, 220)), ("+Y", 90.0, (40, 170, 40)), ("-X", 180.0, (200, 60, 200)),
        ("-Y", 270.0, (200, 160, 30))]


def main(path):
    w, h, margin, label_h = 512, 256, 24, 56
    canvas = np.full((len(CONVENTIONS) * (h + label_h + margin) + margin, w + 2 * margin, 3), 255, np.uint8)
    for k, (name, formula, u_of) in enumerate(CONVENTIONS):
        top = margin + k * (h + label_h + margin) + label_h
        cv2.putText(canvas, f"{name}:  {formula}", (margin, top - 30), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (0, 0, 0), 1,
                    cv2.LINE_AA)
        cv2.putText(canvas, "row 0 = zenith (+Z) in all three; phi = azimuth from +X towards +Y", (margin, top - 10),
                    cv2.FONT_HERSHEY_SIMPLEX, 0.42, (80, 80, 80), 1, cv2.LINE_AA)
        # Sky above the horizon, ground below.
        cv2.rectangle(canvas, (margin, top), (margin + w, top + h // 2), (250, 225, 200), -1)
        cv2.rectangle(canvas, (margin, top + h // 2), (margin + w, top + h), (200, 215, 225), -1)
        cv2.rectangle(canvas, (margin, top), (margin + w, top + h), (0, 0, 0), 1)
        cv2.line(canvas, (margin, top + h // 2), (margin + w, top + h // 2), (90, 90, 90), 1)
        for label, az, colour in AXES:
            u = u_of(math.radians(az)) % 1.0
            x = int(round(margin + u * w))
            cv2.line(canvas, (x, top), (x, top + h), colour, 2)
            cv2.circle(canvas, (x, top + h // 2), 7, colour, -1)
            cv2.putText(canvas, label, (min(x + 6, margin + w - 26), top + h // 2 - 10), cv2.FONT_HERSHEY_SIMPLEX,
                        0.6, colour, 2, cv2.LINE_AA)
        for u in (0.0, 0.25, 0.5, 0.75, 1.0):
            x = int(round(margin + u * w))
            cv2.putText(canvas, f"{u:g}", (max(margin, x - 10), top + h + 16), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                        (0, 0, 0), 1, cv2.LINE_AA)
    if not cv2.imwrite(path, canvas):
        sys.exit(f"cannot write {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "docs/images/envmap_conventions.png")
