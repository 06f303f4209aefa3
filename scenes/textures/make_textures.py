#!/usr/bin/env python3
"""Writes the scene textures (standard library only; the same bytes on every run):
checker.png  64x64 sRGB, 8x8 squares of two warm greys with a thin darker grout line."""
import struct
import zlib
from pathlib import Path


def write_png(path, width, height, rows):
    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF)

    raw = b"".join(b"\x00" + bytes(row) for row in rows)
    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    Path(path).write_bytes(png)


def checker():
    size, cell = 64, 8
    rows = []
    for y in range(size):
        row = []
        for x in range(size):
            light = ((x // cell) + (y // cell)) % 2 == 0
            grout = x % cell == 0 or y % cell == 0
            c = (70, 64, 58) if grout else (200, 190, 175) if light else (120, 112, 104)
            row.extend(c)
        rows.append(row)
    return size, size, rows


if __name__ == "__main__":
    here = Path(__file__).resolve().parent
    w, h, rows = checker()
    write_png(here / "checker.png", w, h, rows)
