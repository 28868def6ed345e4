#!/usr/bin/env python3
"""Writes chalk.png, the speckled tip of the chalk preset: a 64x64 greyscale disc whose
value fades toward the rim and is broken up by deterministic speckle noise (white paints,
black does not). Run from this directory; the PNG is committed, so this is only needed to
change it. Standard library only."""
import math
import struct
import zlib

SIZE = 64


def speckle(x, y):
    """A deterministic hash of the pixel, in [0, 1)."""
    h = (x * 73856093) ^ (y * 19349663) ^ 0x5BD1E995
    h = (h ^ (h >> 13)) * 0x85EBCA6B & 0xFFFFFFFF
    h ^= h >> 16
    return (h & 0xFFFF) / 65536.0


def value(x, y):
    c = (SIZE - 1) / 2.0
    r = math.hypot(x - c, y - c) / (SIZE / 2.0)
    if r >= 1.0:
        return 0
    body = 1.0 - r ** 3
    grain = speckle(x, y)
    # Chalk leaves gaps: a third of the grains paint nothing, the rest vary in strength.
    if grain < 0.33:
        return 0
    return round(255 * body * (0.45 + 0.55 * grain))


def png(width, height, rows):
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    raw = b"".join(b"\x00" + bytes(row) for row in rows)
    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)  # 8-bit greyscale
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


rows = [[value(x, y) for x in range(SIZE)] for y in range(SIZE)]
with open("chalk.png", "wb") as f:
    f.write(png(SIZE, SIZE, rows))
