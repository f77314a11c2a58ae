#!/usr/bin/env python3
"""Side-by-side panel of sRGB PNGs (compare-images --srgb-png writes them from EXRs), with titles.
Usage: figure.py OUT.png TITLE=IMAGE.png ...   (matplotlib; the file is a 256-colour PNG)"""
import io
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg
import matplotlib.pyplot as plt
from PIL import Image


def main():
    out, panels = sys.argv[1], [a.split("=", 1) for a in sys.argv[2:]]
    imgs = [mpimg.imread(p) for _, p in panels]
    h, w = imgs[0].shape[:2]
    dpi = 100
    fig, axes = plt.subplots(1, len(imgs), figsize=(len(imgs) * w / dpi, (h + 22) / dpi), dpi=dpi)
    for ax, (title, _), img in zip(axes, panels, imgs):
        ax.imshow(img, interpolation="nearest")
        ax.set_title(title, fontsize=8, pad=3)
        ax.axis("off")
    fig.subplots_adjust(left=0, right=1, bottom=0, top=(h / (h + 22)), wspace=0.01)
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format="png")
    # Noisy renders compress badly as 24-bit PNG: an adaptive 256-colour palette keeps the file ~4x smaller.
    Image.open(buf).convert("RGB").quantize(256).save(out, optimize=True)


if __name__ == "__main__":
    main()
