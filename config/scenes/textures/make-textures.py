#!/usr/bin/env python3
"""Write hapticd's example height map, cobbles.png, into this directory: 64 x 64 grey
pixels of rounded cobbles (the distance to the nearest of 12 points scattered over the tile,
which repeats seamlessly, turned into a dome over each), for a texture laid in tiles.

Run it again after a change (python3 config/scenes/textures/make-textures.py). Only the
standard library: the PNG is written by hand (one IDAT chunk, filter 0 on every row).
"""

import math
import os
import random
import struct
import zlib

SIDE = 64
STONES = 12


def heights():
    """Each pixel's height, 0 to 1: 1 at a stone's centre, 0 on the seams between stones."""
    rng = random.Random(11)
    centres = [(rng.random(), rng.random()) for _ in range(STONES)]
    rows = []
    for y in range(SIDE):
        row = []
        for x in range(SIDE):
            u, v = (x + 0.5) / SIDE, (y + 0.5) / SIDE
            near = []
            for cx, cy in centres:
                du = min(abs(u - cx), 1 - abs(u - cx))
                dv = min(abs(v - cy), 1 - abs(v - cy))
                near.append(math.hypot(du, dv))
            near.sort()
            # Half way between the two nearest centres is a seam.
            edge = (near[1] - near[0]) / (near[1] + near[0])
            row.append(math.sqrt(max(0.0, min(1.0, 2.0 * edge))))
        rows.append(row)
    return rows


def chunk(kind, data):
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))


def write(path, rows):
    raw = b"".join(b"\x00" + bytes(round(255 * h) for h in row) for row in rows)
    header = struct.pack(">IIBBBBB", SIDE, SIDE, 8, 0, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n")
        f.write(chunk(b"IHDR", header))
        f.write(chunk(b"IDAT", zlib.compress(raw, 9)))
        f.write(chunk(b"IEND", b""))


if __name__ == "__main__":
    write(os.path.join(os.path.dirname(os.path.abspath(__file__)), "cobbles.png"), heights())
