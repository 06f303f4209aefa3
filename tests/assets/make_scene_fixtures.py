#!/usr/bin/env python3
"""Regenerates the glTF scene fixtures in tests/assets/fixtures/scenes/ and the malformed glTF scenes
in tests/malformed/gltf_scene/ (standard library only). The files are committed; run this only to
change them:  python3 tests/assets/make_scene_fixtures.py

The values written here are repeated as literals in tests/assets/gltf_scene_test.cpp."""
import base64
import json
import math
import os
import struct
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENES = os.path.join(ROOT, "tests", "assets", "fixtures", "scenes")
MAL = os.path.join(ROOT, "tests", "malformed", "gltf_scene")

FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(path, "wb") as f:
        f.write(data)


def pad4(b, fill=b"\0"):
    return b + fill * (-len(b) % 4)


def floats(vals):
    return struct.pack("<%df" % len(vals), *vals)


def data_uri(b, mime="application/octet-stream"):
    return "data:%s;base64,%s" % (mime, base64.b64encode(b).decode())


def dump(doc):
    return json.dumps(doc, indent=1) + "\n"


def png(width, height, rgba):
    """An 8-bit RGBA PNG; rgba is a flat list of width * height * 4 values, row 0 first."""
    rows = b""
    for y in range(height):
        rows += b"\0" + bytes(rgba[y * width * 4:(y + 1) * width * 4])

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def glb(doc, bin_bytes):
    js = pad4(json.dumps(doc, separators=(",", ":")).encode(), b" ")
    out = struct.pack("<4sII", b"glTF", 2, 0)
    out += struct.pack("<I4s", len(js), b"JSON") + js
    if bin_bytes is not None:
        b = pad4(bin_bytes)
        out += struct.pack("<I4s", len(b), b"BIN\0") + b
    return out[:8] + struct.pack("<I", len(out)) + out[12:]


class Bin:
    """Accumulates a binary buffer and its bufferViews / accessors."""

    def __init__(self):
        self.data = b""
        self.views = []
        self.accessors = []

    def view(self, payload):
        self.data = pad4(self.data)
        self.views.append({"buffer": 0, "byteOffset": len(self.data), "byteLength": len(payload)})
        self.data += payload
        return len(self.views) - 1

    def accessor(self, payload, component, count, kind, **extra):
        acc = {"bufferView": self.view(payload), "componentType": component, "count": count, "type": kind}
        acc.update(extra)
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def vec3(self, vals):
        n = len(vals) // 3
        lo = [min(vals[i::3]) for i in range(3)]
        hi = [max(vals[i::3]) for i in range(3)]
        return self.accessor(floats(vals), FLOAT, n, "VEC3", min=lo, max=hi)

    def vec2(self, vals):
        return self.accessor(floats(vals), FLOAT, len(vals) // 2, "VEC2")

    def indices(self, vals):
        return self.accessor(struct.pack("<%dH" % len(vals), *vals), USHORT, len(vals), "SCALAR")


def document(b, buffer_uri=True):
    doc = {"asset": {"version": "2.0", "generator": "penumbra make_scene_fixtures.py"},
           "buffers": [{"byteLength": len(b.data)}], "bufferViews": b.views, "accessors": b.accessors}
    if buffer_uri:
        doc["buffers"][0]["uri"] = data_uri(b.data)
    return doc


# A triangle in z = 0 with normals and texture coordinates, as (POSITION, NORMAL, TEXCOORD_0, indices).
TRI_POS = [0, 0, 0, 1, 0, 0, 0, 1, 0]
TRI_NRM = [0, 0, 1] * 3
TRI_UV = [0, 0, 1, 0, 0, 1]


def triangle(b, with_uv1=False):
    attrs = {"POSITION": b.vec3(TRI_POS), "NORMAL": b.vec3(TRI_NRM), "TEXCOORD_0": b.vec2(TRI_UV)}
    if with_uv1:
        attrs["TEXCOORD_1"] = b.vec2([0.5] * 6)
    return {"attributes": attrs, "indices": b.indices([0, 1, 2])}


def quat_axis_angle(axis, angle):
    n = math.sqrt(sum(a * a for a in axis))
    s = math.sin(angle / 2) / n
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2)]


def jpeg_flat_blocks(blocks_x, blocks_y, colour_of):
    """A baseline JPEG (4:4:4, quantisation 1) whose 8 x 8 blocks are each one flat RGB colour
    colour_of(bx, by): only DC coefficients are non-zero, so the image decodes to within rounding of
    the colours. Huffman tables: DC categories 0-11 as 4-bit codes, AC only end-of-block ('0')."""
    width, height = blocks_x * 8, blocks_y * 8

    def segment(marker, payload):
        return bytes([0xFF, marker]) + struct.pack(">H", len(payload) + 2) + payload

    out = b"\xFF\xD8"
    out += segment(0xDB, b"\x00" + b"\x01" * 64)  # 8-bit table 0, all ones
    out += segment(0xC0, struct.pack(">BHHB", 8, height, width, 3) +
                   b"".join(bytes([cid, 0x11, 0]) for cid in (1, 2, 3)))
    counts = [0] * 16
    counts[3] = 12  # twelve 4-bit codes
    out += segment(0xC4, b"\x00" + bytes(counts) + bytes(range(12)))
    counts = [0] * 16
    counts[0] = 1  # one 1-bit code: end of block
    out += segment(0xC4, b"\x10" + bytes(counts) + b"\x00")
    out += segment(0xDA, bytes([3, 1, 0x00, 2, 0x00, 3, 0x00, 0, 63, 0]))

    bits = []

    def put(value, count):
        for i in range(count - 1, -1, -1):
            bits.append((value >> i) & 1)

    previous = [0, 0, 0]
    for by in range(blocks_y):
        for bx in range(blocks_x):
            r, g, b = colour_of(bx, by)
            ycc = (0.299 * r + 0.587 * g + 0.114 * b,
                   -0.168736 * r - 0.331264 * g + 0.5 * b + 128,
                   0.5 * r - 0.418688 * g - 0.081312 * b + 128)
            for c in range(3):
                dc = int(round(8 * (ycc[c] - 128)))
                diff = dc - previous[c]
                previous[c] = dc
                category = abs(diff).bit_length()
                put(category, 4)
                if category:
                    put(diff if diff > 0 else diff + (1 << category) - 1, category)
                put(0, 1)  # end of block
    while len(bits) % 8:
        bits.append(1)
    data = b""
    for i in range(0, len(bits), 8):
        byte = int("".join(map(str, bits[i:i + 8])), 2)
        data += bytes([byte]) + (b"\x00" if byte == 0xFF else b"")
    return out + data + b"\xFF\xD9"


# Quadrant colours of quadrants.jpg (16 x 16: top-left, top-right, bottom-left, bottom-right).
QUADRANTS = [(200, 30, 30), (30, 200, 30), (30, 30, 200), (240, 240, 240)]


# ---- (a) hierarchy.gltf ------------------------------------------------------------------------
def hierarchy():
    b = Bin()
    prim = triangle(b)
    # A quad as a triangle strip (no normals: generated), a second primitive of mesh 1.
    strip = {"attributes": {"POSITION": b.vec3([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0])}, "mode": 5}
    doc = document(b)
    doc["meshes"] = [{"name": "tri", "primitives": [prim]}, {"name": "two", "primitives": [prim, strip]}]
    # "arm": T(0,1,0) * Rz(90 deg) * S(1,2,1) written as a column-major matrix.
    arm = [0, 1, 0, 0,
           -2, 0, 0, 0,
           0, 0, 1, 0,
           0, 1, 0, 1]
    # "mirror": T(-3,0,0) * S(-1,1,1) (negative determinant).
    mirror = [-1, 0, 0, 0,
              0, 1, 0, 0,
              0, 0, 1, 0,
              -3, 0, 0, 1]
    doc["nodes"] = [
        {"name": "root", "translation": [1, 2, 3], "rotation": quat_axis_angle([0, 1, 0], math.pi / 2),
         "scale": [2, 2, 2], "children": [1, 2, 6]},
        {"name": "arm", "matrix": arm, "children": [3]},
        {"name": "mirror", "matrix": mirror, "mesh": 0},
        {"name": "hand", "translation": [0, 0, 2], "rotation": quat_axis_angle([1, 0, 0], math.pi / 4),
         "scale": [1, 0.5, 1], "mesh": 0, "children": [4]},
        {"name": "finger", "translation": [0.5, 0, 0], "mesh": 1},
        {"name": "elsewhere", "translation": [100, 0, 0], "mesh": 0},
        {},
    ]
    doc["scenes"] = [{"name": "main", "nodes": [0]}, {"name": "other", "nodes": [5]}]
    doc["scene"] = 0
    write(os.path.join(SCENES, "hierarchy.gltf"), dump(doc))


# ---- (b) materials.glb -------------------------------------------------------------------------
IMAGE0 = (2, 2, [255, 0, 0, 255, 0, 255, 0, 255,
                 0, 0, 255, 255, 255, 255, 255, 128])
IMAGE1 = (3, 1, [10, 20, 30, 255, 40, 50, 60, 255, 70, 80, 90, 255])


def materials():
    b = Bin()
    tri = triangle(b)
    tri_uv1 = triangle(b, with_uv1=True)
    image0_view = b.view(png(*IMAGE0))
    doc = document(b, buffer_uri=False)
    doc["images"] = [{"bufferView": image0_view, "mimeType": "image/png", "name": "checker"},
                     {"uri": data_uri(png(*IMAGE1), "image/png"), "name": "strip"}]
    doc["samplers"] = [{"magFilter": 9728, "minFilter": 9728}]
    doc["textures"] = [{"source": 0, "sampler": 0}, {"source": 1}]
    doc["materials"] = [
        {"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.1, 0.1, 1.0], "metallicFactor": 0.25,
                                                 "roughnessFactor": 0.75, "baseColorTexture": {"index": 0}}},
        {"name": "glow", "emissiveFactor": [1.0, 0.5, 0.25], "emissiveTexture": {"index": 1},
         "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 1.0}},
        {"name": "maps", "pbrMetallicRoughness": {"metallicRoughnessTexture": {"index": 0}},
         "normalTexture": {"index": 1, "scale": 1.0}, "occlusionTexture": {"index": 0}},
        {"name": "unused", "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}}},
        {"name": "second set", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 0.5],
                                                        "baseColorTexture": {"index": 0, "texCoord": 1}}},
    ]
    doc["meshes"] = [
        {"name": "three", "primitives": [dict(tri, material=0), dict(tri, material=1), dict(tri, material=2)]},
        {"name": "uv1", "primitives": [dict(tri_uv1, material=4)]},
        {"name": "plain", "primitives": [tri]},
    ]
    doc["nodes"] = [{"name": "multi", "mesh": 0}, {"name": "second", "mesh": 1},
                    {"name": "plain", "mesh": 2, "translation": [0, 0, -1]},
                    {"name": "again", "mesh": 0, "translation": [3, 0, 0]}]
    doc["scenes"] = [{"nodes": [0, 1, 2, 3]}]
    doc["scene"] = 0
    write(os.path.join(SCENES, "materials.glb"), glb(doc, b.data))


# ---- (c) camera_lights.gltf ---------------------------------------------------------------------
def camera_lights():
    b = Bin()
    tri = triangle(b)
    doc = document(b)
    doc["meshes"] = [{"primitives": [tri]}]
    doc["extensionsUsed"] = ["KHR_lights_punctual"]
    doc["cameras"] = [
        {"name": "Main", "type": "perspective",
         "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 200.0, "aspectRatio": 1.5}},
        {"name": "Overview", "type": "perspective", "perspective": {"yfov": 1.2, "znear": 0.5}},
        {"name": "Flat", "type": "orthographic",
         "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0}},
    ]
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"name": "Sun", "type": "directional", "color": [1.0, 0.9, 0.8], "intensity": 3.0},
        {"name": "Bulb", "type": "point", "color": [0.2, 0.4, 1.0], "intensity": 20.0, "range": 15.0},
        {"name": "Spot", "type": "spot", "intensity": 5.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}},
    ]}}
    doc["nodes"] = [
        {"name": "MainCamNode", "camera": 0, "translation": [0, 1, 10]},
        {"name": "TopCamNode", "camera": 1, "translation": [0, 20, 0],
         "rotation": quat_axis_angle([1, 0, 0], -math.pi / 2)},
        {"name": "FlatCamNode", "camera": 2},
        {"name": "SunNode", "rotation": quat_axis_angle([1, 0, 0], -math.pi / 2),
         "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "BulbNode", "translation": [1, 2, 3], "extensions": {"KHR_lights_punctual": {"light": 1}},
         "mesh": 0},
        {"name": "SpotNode", "translation": [0, 5, 0], "extensions": {"KHR_lights_punctual": {"light": 2}}},
    ]
    doc["scenes"] = [{"nodes": [0, 1, 2, 3, 4, 5]}]
    doc["scene"] = 0
    write(os.path.join(SCENES, "camera_lights.gltf"), dump(doc))


# ---- (d) jpeg_texture.gltf: an external JPEG file as base colour ------------------------------------
def jpeg_texture():
    write(os.path.join(SCENES, "quadrants.jpg"), jpeg_flat_blocks(2, 2, lambda bx, by: QUADRANTS[by * 2 + bx]))
    b = Bin()
    tri = triangle(b)
    doc = document(b)
    doc["images"] = [{"uri": "quadrants.jpg"}]
    doc["textures"] = [{"source": 0}]
    doc["materials"] = [{"name": "photo", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    doc["meshes"] = [{"primitives": [dict(tri, material=0)]}]
    doc["nodes"] = [{"name": "picture", "mesh": 0}]
    write(os.path.join(SCENES, "jpeg_texture.gltf"), dump(doc))


# ---- malformed scenes ---------------------------------------------------------------------------
def base_doc():
    """One textured triangle with a material, a camera and a light: each malformed file breaks one thing."""
    b = Bin()
    tri = triangle(b)
    doc = document(b)
    doc["images"] = [{"uri": data_uri(png(*IMAGE1), "image/png")}]
    doc["samplers"] = [{}]
    doc["textures"] = [{"source": 0, "sampler": 0}]
    doc["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    doc["meshes"] = [{"primitives": [dict(tri, material=0)]}]
    doc["cameras"] = [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 1.0, "zfar": 100.0}}]
    doc["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point"}]}}
    doc["nodes"] = [{"name": "n", "mesh": 0, "camera": 0, "children": [1]},
                    {"name": "lamp", "extensions": {"KHR_lights_punctual": {"light": 0}}}]
    doc["scenes"] = [{"nodes": [0]}]
    doc["scene"] = 0
    return doc


def malformed():
    out = {}

    def bad(name, mutate):
        doc = base_doc()
        mutate(doc)
        out[name] = doc

    bad("material_index_out_of_range", lambda d: d["meshes"][0]["primitives"][0].update(material=3))
    bad("texture_index_out_of_range",
        lambda d: d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"].update(index=2))
    bad("emissive_texture_index_negative", lambda d: d["materials"][0].update(emissiveTexture={"index": -4}))
    bad("texture_source_out_of_range", lambda d: d["textures"][0].update(source=5))
    bad("texture_sampler_out_of_range", lambda d: d["textures"][0].update(sampler=1))
    bad("texture_without_source", lambda d: d["textures"][0].pop("source"))
    bad("image_not_an_image", lambda d: d["images"][0].update(uri=data_uri(b"hello, I am not a picture")))
    huge = bytearray(png(*IMAGE1))
    huge[16:24] = struct.pack(">II", 100000, 100000)
    bad("image_huge_dimensions", lambda d: d["images"][0].update(uri=data_uri(bytes(huge), "image/png")))
    bad("image_truncated_png", lambda d: d["images"][0].update(uri=data_uri(png(*IMAGE1)[:45], "image/png")))
    bad("image_missing_file", lambda d: d["images"][0].update(uri="missing.png"))
    bad("texture_uri_escape", lambda d: d["images"][0].update(uri="../../textures/escape.png"))
    bad("material_factor_out_of_range",
        lambda d: d["materials"][0]["pbrMetallicRoughness"].update(metallicFactor=2.0))
    bad("camera_znear_zero", lambda d: d["cameras"][0]["perspective"].update(znear=0.0))
    bad("camera_zfar_below_znear", lambda d: d["cameras"][0]["perspective"].update(zfar=0.5))
    bad("camera_yfov_too_large", lambda d: d["cameras"][0]["perspective"].update(yfov=3.5))
    bad("camera_index_out_of_range", lambda d: d["nodes"][0].update(camera=3))
    bad("light_index_out_of_range", lambda d: d["nodes"][1]["extensions"]["KHR_lights_punctual"].update(light=4))
    bad("light_unknown_type", lambda d: d["extensions"]["KHR_lights_punctual"]["lights"][0].update(type="area"))
    bad("lights_not_an_array", lambda d: d["extensions"]["KHR_lights_punctual"].update(lights={"type": "point"}))
    bad("light_negative_intensity",
        lambda d: d["extensions"]["KHR_lights_punctual"]["lights"][0].update(intensity=-1.0))
    bad("node_singular_matrix",
        lambda d: d["nodes"][1].update(matrix=[1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]))
    bad("node_sheared_matrix",
        lambda d: d["nodes"][0].update(matrix=[1, 0, 0, 0, 0.5, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]))
    bad("node_projective_matrix",
        lambda d: d["nodes"][0].update(matrix=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, -1, 0, 0, 0, 1]))
    bad("node_cycle", lambda d: d["nodes"][1].update(children=[0]))
    bad("indices_accessor_out_of_range", lambda d: d["meshes"][0]["primitives"][0].update(indices=7))
    bad("position_accessor_out_of_view", lambda d: d["accessors"][0].update(count=1000))

    def nan_position(d):
        b = Bin()
        pos = b.vec3(TRI_POS)
        b.data = b.data[:12] + struct.pack("<f", float("nan")) + b.data[16:]
        del b.accessors[pos]["min"], b.accessors[pos]["max"]
        nrm, uv, idx = b.vec3(TRI_NRM), b.vec2(TRI_UV), b.indices([0, 1, 2])
        d.update(document(b))
        d["meshes"][0]["primitives"][0].update(attributes={"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv},
                                               indices=idx)

    bad("nan_position", nan_position)
    for name, doc in out.items():
        write(os.path.join(MAL, name + ".gltf"), dump(doc))

    # yfov = 1e999 (JSON has no NaN or infinity; an overflowing number is as close as text gets).
    text = dump(base_doc()).replace('"yfov": 1.0', '"yfov": 1e999')
    assert "1e999" in text
    write(os.path.join(MAL, "camera_yfov_overflow.gltf"), text)

    # GLB whose image bufferView runs past the end of the BIN chunk.
    b = Bin()
    tri = triangle(b)
    image_view = b.view(png(*IMAGE0))
    b.views[image_view]["byteLength"] += 4096
    doc = document(b, buffer_uri=False)
    doc["images"] = [{"bufferView": image_view, "mimeType": "image/png"}]
    doc["textures"] = [{"source": 0}]
    doc["materials"] = [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
    doc["meshes"] = [{"primitives": [dict(tri, material=0)]}]
    doc["nodes"] = [{"mesh": 0}]
    doc["scenes"] = [{"nodes": [0]}]
    write(os.path.join(MAL, "image_view_out_of_buffer.glb"), glb(doc, b.data))


if __name__ == "__main__":
    hierarchy()
    materials()
    camera_lights()
    jpeg_texture()
    malformed()
