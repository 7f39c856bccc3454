#!/usr/bin/python3
# SPDX-License-Identifier: Apache-2.0
"""Writes a .y4m video (4:2:0, 8-bit) for Chromium's fake camera: an image scaled to the frame's
height and placed at the left or the centre, on grey, repeated for N frames.

    make_y4m.py IMAGE OUT.y4m [--width 640] [--height 360] [--frames 15] [--place left|center]
"""
import argparse

import numpy as np
from skimage import io, transform


def to_yuv420(rgb):
    rgb = rgb.astype(np.float32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    y = 0.299 * r + 0.587 * g + 0.114 * b
    u = (b - y) * 0.564 + 128
    v = (r - y) * 0.713 + 128
    sub = lambda c: c.reshape(c.shape[0] // 2, 2, c.shape[1] // 2, 2).mean(axis=(1, 3))
    clip = lambda c: np.clip(np.rint(c), 0, 255).astype(np.uint8)
    return clip(y), clip(sub(u)), clip(sub(v))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("image")
    p.add_argument("out")
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=360)
    p.add_argument("--frames", type=int, default=15)
    p.add_argument("--place", choices=["left", "center"], default="left")
    a = p.parse_args()
    img = io.imread(a.image)
    if img.ndim == 2:
        img = np.stack([img] * 3, axis=-1)
    img = img[..., :3]
    scale = a.height / img.shape[0]
    w = min(a.width, int(round(img.shape[1] * scale)))
    small = transform.resize(img, (a.height, w), anti_aliasing=True, preserve_range=True)
    canvas = np.full((a.height, a.width, 3), 96, dtype=np.float32)
    x0 = 0 if a.place == "left" else (a.width - w) // 2
    canvas[:, x0:x0 + w] = small
    y, u, v = to_yuv420(canvas)
    with open(a.out, "wb") as f:
        f.write(f"YUV4MPEG2 W{a.width} H{a.height} F15:1 Ip A1:1 C420jpeg\n".encode())
        for _ in range(a.frames):
            f.write(b"FRAME\n")
            f.write(y.tobytes())
            f.write(u.tobytes())
            f.write(v.tobytes())


if __name__ == "__main__":
    main()
