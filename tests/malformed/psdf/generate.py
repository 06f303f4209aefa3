#!/usr/bin/env python3
"""Writes the malformed .psdf corpus (and three valid files) next to this script.

Every file is built from one small valid grid and then broken in exactly one way; header fields are
re-checksummed after the change (unless the header CRC itself is the point), so the reader's
message must name the field, not just the CRC. The byte layout is the one in docs/FORMATS.md.
tests/sdf/psdf_malformed_test.cpp maps each file name to the keyword its error must contain.
Run: python3 tests/malformed/psdf/generate.py
"""
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
HEADER = 144


def header(dims, origin, voxel, encoding, flags, band, bmin, bmax, dmin, dmax, payload_bytes, payload_crc,
           version=1, reserved=0, magic=b"PSDF"):
    h = bytearray()
    h += magic
    h += struct.pack("<I", version)
    h += struct.pack("<3I", *dims)
    h += struct.pack("<I", encoding)
    h += struct.pack("<3d", *origin)
    h += struct.pack("<d", voxel)
    h += struct.pack("<I", flags)
    h += struct.pack("<I", reserved)
    h += struct.pack("<d", band)
    h += struct.pack("<3d", *bmin)
    h += struct.pack("<3d", *bmax)
    h += struct.pack("<f", dmin)
    h += struct.pack("<f", dmax)
    h += struct.pack("<Q", payload_bytes)
    h += struct.pack("<I", payload_crc)
    assert len(h) == HEADER - 4
    h += struct.pack("<I", zlib.crc32(bytes(h)))
    return h


def f32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


class Grid:
    def __init__(self, encoding=0):
        self.dims = [4, 3, 2]
        self.origin = [-1.0, -2.0, -3.0]
        self.voxel = 0.5
        self.encoding = encoding
        self.flags = 0 | (1 << 2)  # winding, closed manifold
        self.band = 1.0 if encoding == 2 else 0.0
        # Voxel centres span [-0.75, 0.75] x [-1.75, -0.75] x [-2.75, -2.25]; the mesh lies inside.
        self.bmin = [-0.5, -1.5, -2.6]
        self.bmax = [0.5, -1.0, -2.4]
        n = self.dims[0] * self.dims[1] * self.dims[2]
        self.values = [f32(0.1 * i - 1.0) for i in range(n)]
        self.version = 1
        self.reserved = 0
        self.magic = b"PSDF"
        self.payload_bytes = None
        self.payload_crc = None
        self.dmin = None
        self.dmax = None

    def payload(self):
        if self.encoding == 0:
            return b"".join(struct.pack("<f", v) for v in self.values)
        if self.encoding == 1:
            return b"".join(struct.pack("<e", v) for v in self.values)
        if self.encoding == 2:
            out = bytearray()
            for v in self.values:
                t = max(-1.0, min(1.0, v / self.band))
                out.append(int(max(0, min(255, round((t + 1.0) * 127.5)))))
            return bytes(out)
        return b"\0" * (4 * len(self.values))

    def decoded(self):
        if self.encoding == 1:
            return [struct.unpack("<e", struct.pack("<e", v))[0] for v in self.values]
        if self.encoding == 2:
            return [f32((q / 255.0 * 2.0 - 1.0) * self.band) for q in self.payload()]
        return self.values

    def build(self):
        p = self.payload()
        dec = [v for v in self.decoded() if math.isfinite(v)]
        h = header(self.dims, self.origin, self.voxel, self.encoding, self.flags, self.band, self.bmin, self.bmax,
                   self.dmin if self.dmin is not None else min(dec), self.dmax if self.dmax is not None else max(dec),
                   self.payload_bytes if self.payload_bytes is not None else len(p),
                   self.payload_crc if self.payload_crc is not None else zlib.crc32(p),
                   version=self.version, reserved=self.reserved, magic=self.magic)
        return bytes(h) + p


def write(name, data):
    with open(os.path.join(HERE, name), "wb") as f:
        f.write(data)


def variant(name, **changes):
    g = Grid(changes.pop("encoding", 0))
    for k, v in changes.items():
        setattr(g, k, v)
    write(name, g.build())


def main():
    for enc, name in ((0, "f32"), (1, "f16"), (2, "u8")):
        write("valid_%s.psdf" % name, Grid(enc).build())
    good = Grid().build()

    write("empty.psdf", b"")
    write("bad_magic.psdf", b"GLTF" + good[4:])
    write("truncated_magic.psdf", good[:2])
    write("truncated_header.psdf", good[:60])
    variant("future_version.psdf", version=2)
    corrupt = bytearray(good)
    corrupt[30] ^= 0x40  # inside origin.x, CRC left as it was
    write("header_crc_wrong.psdf", bytes(corrupt))
    variant("zero_dims.psdf", dims=[4, 0, 2], values=[], payload_bytes=0, dmin=0.0, dmax=0.0)
    variant("dims_over_axis_limit.psdf", dims=[0xFFFFFFFF, 0xFFFFFFFF, 0xFFFFFFFF])
    variant("dims_product_overflow.psdf", dims=[16384, 16384, 16384])
    # 4096 x 4096 x 64 = 2^30 voxels (exactly the default cap): a consistent 4 GiB declaration in a
    # 240-byte file must be refused before any allocation.
    variant("huge_dims_tiny_file.psdf", dims=[4096, 4096, 64], payload_bytes=4096 * 4096 * 64 * 4)
    variant("payload_size_mismatch.psdf", payload_bytes=100)
    write("truncated_payload.psdf", good[:-10])
    write("trailing_bytes.psdf", good + b"\0\0\0\0")
    corrupt = bytearray(good)
    corrupt[HEADER + 5] ^= 0x01
    write("bad_payload_crc.psdf", bytes(corrupt))
    variant("nan_origin.psdf", origin=[-1.0, float("nan"), -3.0])
    variant("inf_origin.psdf", origin=[float("inf"), -2.0, -3.0])
    variant("negative_voxel_size.psdf", voxel=-0.5)
    variant("zero_voxel_size.psdf", voxel=0.0)
    variant("inf_voxel_size.psdf", voxel=float("inf"))
    variant("far_corner_overflow.psdf", origin=[1e308, 0.0, 0.0], voxel=1e308, bmin=[0, 0, 0], bmax=[0, 0, 0])
    # Finite grids whose distances 32-bit floats cannot hold (issue 8, item 14): a diagonal beyond
    # FLT_MAX, a voxel below the smallest normal float, a u8 band wider than FLT_MAX.
    variant("voxel_size_1e300.psdf", origin=[0.0, 0.0, 0.0], voxel=1e300, bmin=[0, 0, 0], bmax=[0, 0, 0])
    variant("voxel_size_subnormal_float.psdf", origin=[0.0, 0.0, 0.0], voxel=1e-40, bmin=[0, 0, 0],
            bmax=[0, 0, 0])
    variant("u8_band_width_huge.psdf", encoding=2, band=1e39)
    variant("unknown_encoding.psdf", encoding=7)
    # u8 payloads quantised with band width 1.0, header band width replaced
    for name, band in (("u8_band_width_zero.psdf", 0.0), ("u8_band_width_nan.psdf", float("nan"))):
        g = Grid(2)
        p = g.payload()
        h = header(g.dims, g.origin, g.voxel, 2, g.flags, band, g.bmin, g.bmax, min(g.decoded()),
                   max(g.decoded()), len(p), zlib.crc32(p))
        write(name, bytes(h) + p)
    variant("f32_band_width_nonzero.psdf", band=2.0)
    variant("unknown_flags.psdf", flags=0x100)
    variant("contradictory_flags.psdf", flags=(1 << 2) | (1 << 3))
    variant("reserved_nonzero.psdf", reserved=1)
    variant("nan_bounds.psdf", bmin=[float("nan"), 0.0, 0.0])
    variant("inverted_bounds.psdf", bmin=[1.0, -1.5, -2.6], bmax=[0.5, -1.0, -2.4])
    g = Grid()
    g.values = list(g.values)
    g.values[7] = float("nan")
    write("nan_payload_value.psdf", g.build())
    g = Grid(1)
    g.values = list(g.values)
    g.values[3] = float("inf")
    write("f16_inf_payload_value.psdf", g.build())
    variant("nan_min_distance.psdf", dmin=float("nan"))
    variant("min_max_mismatch.psdf", dmax=5.0)


if __name__ == "__main__":
    main()
