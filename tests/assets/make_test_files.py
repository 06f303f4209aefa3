#!/usr/bin/env python3
"""Regenerates the glTF fixtures in tests/assets/fixtures/ and the malformed meshes in
tests/malformed/{ply,obj,gltf}/ (they double as fuzz seeds). The files are committed; run this only
to change them:  python3 tests/assets/make_test_files.py"""
import base64
import json
import math
import os
import struct

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIX = os.path.join(ROOT, "tests", "assets", "fixtures")
MAL = os.path.join(ROOT, "tests", "malformed")

FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(path, "wb") as f:
        f.write(data)


def pad4(b):
    return b + b"\0" * (-len(b) % 4)


def data_uri(b):
    return "data:application/octet-stream;base64," + base64.b64encode(b).decode()


def floats(vals):
    return struct.pack("<%df" % len(vals), *vals)


def gltf_doc(buffers, views, accessors, meshes, nodes=None, scenes=None, scene=None):
    doc = {"asset": {"version": "2.0", "generator": "penumbra make_test_files.py"},
           "buffers": buffers, "bufferViews": views, "accessors": accessors, "meshes": meshes}
    if nodes is not None:
        doc["nodes"] = nodes
    if scenes is not None:
        doc["scenes"] = scenes
    if scene is not None:
        doc["scene"] = scene
    return doc


def dump(doc):
    return json.dumps(doc, indent=1) + "\n"


# --- one triangle, the base of most glTF files -------------------------------------------------
TRI_POS = floats([0, 0, 0, 1, 0, 0, 0, 1, 0])           # 36 bytes
TRI_IDX = pad4(struct.pack("<3H", 0, 1, 2))              # 8 bytes
TRI_BIN = TRI_POS + TRI_IDX


def triangle_doc(uri=None):
    return gltf_doc(
        buffers=[{"byteLength": len(TRI_BIN), "uri": uri or data_uri(TRI_BIN)}],
        views=[{"buffer": 0, "byteOffset": 0, "byteLength": 36},
               {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
        accessors=[{"bufferView": 0, "componentType": FLOAT, "count": 3, "type": "VEC3",
                    "min": [0, 0, 0], "max": [1, 1, 0]},
                   {"bufferView": 1, "componentType": USHORT, "count": 3, "type": "SCALAR"}],
        meshes=[{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        nodes=[{"mesh": 0}], scenes=[{"nodes": [0]}], scene=0)


def glb(doc, bin_bytes):
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    out = struct.pack("<4sII", b"glTF", 2, 0)
    out += struct.pack("<I4s", len(js), b"JSON") + js
    if bin_bytes is not None:
        b = pad4(bin_bytes)
        out += struct.pack("<I4s", len(b), b"BIN\0") + b
    return out[:8] + struct.pack("<I", len(out)) + out[12:]


def fixtures():
    # Node hierarchy with TRS, matrix and a mirroring scale; node 4 is outside the scene.
    s = math.sqrt(0.5)
    doc = triangle_doc()
    doc["nodes"] = [
        {"name": "root", "translation": [10, 0, 0], "scale": [2, 2, 2], "children": [1, 2]},
        {"name": "rotated", "rotation": [0, 0, s, s], "mesh": 0},
        {"name": "matrix", "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 5, 1], "mesh": 0,
         "children": [3]},
        {"name": "mirrored", "scale": [-1, 1, 1], "mesh": 0},
        {"name": "not_in_scene", "translation": [100, 0, 0], "mesh": 0},
    ]
    doc["scenes"] = [{"nodes": [0]}, {"nodes": [4]}]
    doc["scene"] = 0
    write(os.path.join(FIX, "hierarchy.gltf"), dump(doc))

    # Unit cube [0,1]^3 in a GLB with a BIN chunk, outward-facing triangles.
    pos = []
    for i in range(8):
        pos += [i & 1, (i >> 1) & 1, (i >> 2) & 1]
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    idx = []
    for a, b, c, d in quads:
        idx += [a, b, c, a, c, d]
    pos_b = floats(pos)
    idx_b = struct.pack("<%dH" % len(idx), *idx)
    bin_b = pos_b + pad4(idx_b)
    doc = gltf_doc(
        buffers=[{"byteLength": len(bin_b)}],
        views=[{"buffer": 0, "byteOffset": 0, "byteLength": len(pos_b)},
               {"buffer": 0, "byteOffset": len(pos_b), "byteLength": len(idx_b)}],
        accessors=[{"bufferView": 0, "componentType": FLOAT, "count": 8, "type": "VEC3",
                    "min": [0, 0, 0], "max": [1, 1, 1]},
                   {"bufferView": 1, "componentType": USHORT, "count": len(idx), "type": "SCALAR"}],
        meshes=[{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "mode": 4}]}],
        nodes=[{"mesh": 0}], scenes=[{"nodes": [0]}], scene=0)
    write(os.path.join(FIX, "cube.glb"), glb(doc, bin_b))

    # The same unit cube with every triangle facing inward (an inside-out mesh), as ASCII PLY.
    text = ply_header("ascii", 8, 12).decode()
    for i in range(8):
        text += "%d %d %d\n" % (i & 1, (i >> 1) & 1, (i >> 2) & 1)
    for a, b, c, d in quads:
        text += "3 %d %d %d\n3 %d %d %d\n" % (a, c, b, a, d, c)
    write(os.path.join(FIX, "inside_out_cube.ply"), text)

    # Quad with interleaved position + normal (stride 24) and ubyte indices in an external .bin;
    # no scenes: every root node is used.
    inter = []
    for p in [(0, 0, 0), (2, 0, 0), (2, 3, 0), (0, 3, 0)]:
        inter += list(p) + [0, 0, 1]
    inter_b = floats(inter)
    qidx = bytes([0, 1, 2, 0, 2, 3])
    bin_b = inter_b + pad4(qidx)
    write(os.path.join(FIX, "external.bin"), bin_b)
    doc = gltf_doc(
        buffers=[{"byteLength": len(bin_b), "uri": "external.bin"}],
        views=[{"buffer": 0, "byteOffset": 0, "byteLength": len(inter_b), "byteStride": 24},
               {"buffer": 0, "byteOffset": len(inter_b), "byteLength": 6}],
        accessors=[{"bufferView": 0, "byteOffset": 0, "componentType": FLOAT, "count": 4, "type": "VEC3",
                    "min": [0, 0, 0], "max": [2, 3, 0]},
                   {"bufferView": 0, "byteOffset": 12, "componentType": FLOAT, "count": 4, "type": "VEC3"},
                   {"bufferView": 1, "componentType": UBYTE, "count": 6, "type": "SCALAR"}],
        meshes=[{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        nodes=[{"mesh": 0, "translation": [0, 0, 1]}])
    write(os.path.join(FIX, "external.gltf"), dump(doc))

    # Sparse accessor (vertex 2 moved to (0,5,0)) and a triangle strip (4 vertices, 2 triangles).
    strip = floats([0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0])
    sp_idx = pad4(struct.pack("<H", 2))
    sp_val = floats([0, 5, 0])
    bin_b = TRI_POS + strip + sp_idx + sp_val
    o_strip, o_si = len(TRI_POS), len(TRI_POS) + len(strip)
    o_sv = o_si + len(sp_idx)
    doc = gltf_doc(
        buffers=[{"byteLength": len(bin_b), "uri": data_uri(bin_b)}],
        views=[{"buffer": 0, "byteOffset": 0, "byteLength": 36},
               {"buffer": 0, "byteOffset": o_strip, "byteLength": len(strip)},
               {"buffer": 0, "byteOffset": o_si, "byteLength": 2},
               {"buffer": 0, "byteOffset": o_sv, "byteLength": 12}],
        accessors=[{"bufferView": 0, "componentType": FLOAT, "count": 3, "type": "VEC3",
                    "sparse": {"count": 1, "indices": {"bufferView": 2, "componentType": USHORT},
                               "values": {"bufferView": 3}}},
                   {"bufferView": 1, "componentType": FLOAT, "count": 4, "type": "VEC3"}],
        meshes=[{"primitives": [{"attributes": {"POSITION": 0}},
                                {"attributes": {"POSITION": 1}, "mode": 5}]}],
        nodes=[{"mesh": 0}], scenes=[{"nodes": [0]}])
    write(os.path.join(FIX, "sparse_strip.gltf"), dump(doc))


def ply_header(fmt, vcount, fcount, vprops=("float x", "float y", "float z"),
               flist="list uchar int vertex_indices"):
    h = "ply\nformat %s 1.0\nelement vertex %d\n" % (fmt, vcount)
    h += "".join("property %s\n" % p for p in vprops)
    h += "element face %d\nproperty %s\nend_header\n" % (fcount, flist)
    return h.encode()


def malformed_ply():
    d = os.path.join(MAL, "ply")
    tri_ascii = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    good_bin = ply_header("binary_little_endian", 3, 1) + floats([0, 0, 0, 1, 0, 0, 0, 1, 0]) + \
        struct.pack("<B3i", 3, 0, 1, 2)
    write(os.path.join(d, "truncated_binary.ply"), good_bin[:-5])
    write(os.path.join(d, "truncated_ascii.ply"), ply_header("ascii", 3, 1) + b"0 0 0\n1 0 0\n0 1 0\n3 0 1")
    write(os.path.join(d, "ascii_count_larger_than_file.ply"),
          ply_header("ascii", 4, 1) + b"0 0 0\n1 0 0\n0 1 0\n")
    write(os.path.join(d, "bad_magic.ply"), b"plx\n" + ply_header("ascii", 3, 1)[4:] + tri_ascii.encode())
    # 2^31 vertices declared in a file of well under 1 KB: refused before any allocation.
    write(os.path.join(d, "vertex_count_2pow31.ply"),
          ply_header("binary_little_endian", 2**31, 1) + b"\0" * 200)
    write(os.path.join(d, "face_count_huge.ply"),
          ply_header("ascii", 3, 2**40) + tri_ascii.encode())
    write(os.path.join(d, "count_not_a_number.ply"),
          b"ply\nformat ascii 1.0\nelement vertex -3\nproperty float x\nend_header\n")
    write(os.path.join(d, "negative_list_count.ply"),
          ply_header("binary_little_endian", 3, 1, flist="list char int vertex_indices") +
          floats([0, 0, 0, 1, 0, 0, 0, 1, 0]) + struct.pack("<b3i", -1, 0, 1, 2))
    write(os.path.join(d, "huge_list_count.ply"),
          ply_header("binary_big_endian", 3, 1, flist="list uint int vertex_indices") +
          struct.pack(">9f", 0, 0, 0, 1, 0, 0, 0, 1, 0) + struct.pack(">I3i", 0xFFFFFFF0, 0, 1, 2))
    write(os.path.join(d, "ascii_list_count_out_of_range.ply"),
          ply_header("ascii", 3, 1) + b"0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n")
    write(os.path.join(d, "index_out_of_range.ply"),
          ply_header("ascii", 3, 1) + b"0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")
    write(os.path.join(d, "negative_index.ply"),
          ply_header("ascii", 3, 1) + b"0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n")
    write(os.path.join(d, "nan_vertex.ply"),
          ply_header("ascii", 3, 1) + b"0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n")
    write(os.path.join(d, "inf_vertex_binary.ply"),
          ply_header("binary_little_endian", 3, 1) + floats([0, 0, 0, 1, 0, float("inf"), 0, 1, 0]) +
          struct.pack("<B3i", 3, 0, 1, 2))
    write(os.path.join(d, "float_overflow.ply"),
          ply_header("ascii", 3, 1) + b"0 0 0\n1e999 0 0\n0 1 0\n3 0 1 2\n")
    write(os.path.join(d, "unknown_format.ply"),
          ply_header("binary_middle_endian", 3, 1) + b"\0" * 64)
    write(os.path.join(d, "no_end_header.ply"),
          b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n")
    write(os.path.join(d, "missing_z.ply"),
          ply_header("ascii", 3, 1, vprops=("float x", "float y")) + b"0 0\n1 0\n0 1\n3 0 1 2\n")
    write(os.path.join(d, "bad_number.ply"),
          ply_header("ascii", 3, 1) + b"0 0 0\n1 0.5abc 0\n0 1 0\n3 0 1 2\n")
    write(os.path.join(d, "float_face_indices.ply"),
          ply_header("ascii", 3, 1, flist="list uchar float vertex_indices") + tri_ascii.encode())
    write(os.path.join(d, "unknown_type.ply"),
          ply_header("ascii", 3, 1, vprops=("float x", "float y", "quad z")) + tri_ascii.encode())
    write(os.path.join(d, "empty.ply"), b"")


def malformed_obj():
    d = os.path.join(MAL, "obj")
    write(os.path.join(d, "face_index_out_of_range.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n")
    write(os.path.join(d, "negative_index_out_of_range.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -9\n")
    write(os.path.join(d, "zero_index.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n")
    garbage = bytes((i * 197 + 13) % 256 for i in range(2048))
    write(os.path.join(d, "garbage.obj"), garbage)
    write(os.path.join(d, "no_faces.obj"), "# only points\nv 0 0 0\nv 1 0 0\nv 0 1 0\n")
    write(os.path.join(d, "inf_vertex.obj"), "v 0 0 0\nv 1e999 0 0\nv 0 1 0\nf 1 2 3\n")
    write(os.path.join(d, "empty.obj"), b"")


def malformed_gltf():
    d = os.path.join(MAL, "gltf")

    def put(name, doc):
        write(os.path.join(d, name), dump(doc))

    write(os.path.join(d, "bad_json.gltf"), dump(triangle_doc())[:-40] + "}}\n")
    write(os.path.join(d, "deep_json.gltf"), '{"asset":{"version":"2.0"},"extras":' + "[" * 10000 +
          "]" * 10000 + "}\n")

    doc = triangle_doc()
    doc["accessors"][0]["count"] = 4                     # 4 x 12 bytes > 36-byte view
    put("accessor_out_of_view.gltf", doc)
    doc = triangle_doc()
    doc["bufferViews"][0]["byteLength"] = 400            # view larger than the 44-byte buffer
    put("view_out_of_buffer.gltf", doc)
    doc = triangle_doc()
    doc["bufferViews"][0]["byteStride"] = 8              # < 12-byte VEC3 float
    put("stride_too_small.gltf", doc)
    doc = triangle_doc()
    doc["accessors"][0]["byteOffset"] = 18446744073709551600  # offset + size wraps in 64 bits
    put("offset_overflow.gltf", doc)
    doc = triangle_doc()
    doc["accessors"][0]["count"] = 4611686018427387904   # 2^62 elements
    put("huge_count.gltf", doc)
    put("uri_parent_escape.gltf", triangle_doc("../../etc/passwd"))
    put("uri_percent_escape.gltf", triangle_doc("%2e%2e/%2e%2e/etc/passwd"))
    put("uri_absolute.gltf", triangle_doc("/etc/passwd"))
    put("uri_scheme.gltf", triangle_doc("file:///etc/passwd"))
    doc = triangle_doc("missing.bin")
    put("uri_missing_file.gltf", doc)
    doc = triangle_doc()
    doc["nodes"] = [{"children": [2]}, {"children": [2]}, {"mesh": 0}]
    doc["scenes"] = [{"nodes": [0, 1]}]
    put("node_two_parents.gltf", doc)
    doc = triangle_doc()
    doc["nodes"] = [{"mesh": 0}, {"children": [2]}, {"children": [1], "mesh": 0}]
    doc["scenes"] = [{"nodes": [0]}]
    put("node_cycle.gltf", doc)
    doc = triangle_doc()
    doc["nodes"] = [{"children": [0], "mesh": 0}]
    put("node_self_child.gltf", doc)
    doc = triangle_doc()
    doc["nodes"] = [{"children": [5], "mesh": 0}]
    put("node_child_out_of_range.gltf", doc)

    bin_b = TRI_POS + pad4(struct.pack("<3H", 0, 1, 3))
    doc = triangle_doc(data_uri(bin_b))
    put("index_out_of_range.gltf", doc)

    doc = triangle_doc()
    doc["accessors"][0]["componentType"] = USHORT        # quantized POSITION: refused
    put("position_not_float.gltf", doc)
    doc = triangle_doc()
    doc["accessors"][1]["componentType"] = FLOAT         # float indices: refused
    put("indices_float.gltf", doc)

    bin_b = floats([0, 0, 0, 1, float("nan"), 0, 0, 1, 0]) + TRI_IDX
    put("nan_position.gltf", triangle_doc(data_uri(bin_b)))
    doc = triangle_doc()
    doc["meshes"][0]["primitives"][0]["mode"] = 9
    put("bad_mode.gltf", doc)
    doc = triangle_doc()
    doc["meshes"][0]["primitives"][0]["attributes"] = {"NORMAL": 0}
    put("no_position.gltf", doc)

    doc = triangle_doc()
    del doc["buffers"][0]["uri"]
    good = glb(doc, TRI_BIN)
    write(os.path.join(d, "truncated.glb"), good[: len(good) - 30])
    write(os.path.join(d, "bad_magic.glb"), b"gLTF" + good[4:])
    bad = bytearray(good)
    struct.pack_into("<I", bad, 12, 0x7FFFFFF0)          # JSON chunk longer than the file
    write(os.path.join(d, "json_chunk_too_long.glb"), bytes(bad))
    js_len = struct.unpack_from("<I", good, 12)[0]
    bad = bytearray(good)
    struct.pack_into("<I", bad, 20 + js_len, 0xFFFFFFFC)  # BIN chunk longer than the file
    write(os.path.join(d, "bin_chunk_too_long.glb"), bytes(bad))
    # buffer 0 (the BIN chunk) declared with byteLength 0: tinygltf threw vector::_M_range_check
    doc = triangle_doc()
    del doc["buffers"][0]["uri"]
    doc["buffers"][0]["byteLength"] = 0
    write(os.path.join(d, "glb_buffer_length_zero.glb"), glb(doc, TRI_BIN))
    doc["buffers"][0]["byteLength"] = len(TRI_BIN) + 4   # longer than the BIN chunk
    write(os.path.join(d, "glb_buffer_longer_than_bin.glb"), glb(doc, TRI_BIN))
    doc["buffers"][0]["byteLength"] = len(TRI_BIN)       # no BIN chunk at all
    write(os.path.join(d, "glb_no_bin_chunk.glb"), glb(doc, None))
    # the scene lists its root node three times (the schema requires unique roots; each listing
    # instanced the whole tree again: 20 000 listings in 62 KB took 1.1 GB)
    doc = triangle_doc()
    doc["scenes"] = [{"nodes": [0, 0, 0]}]
    put("scene_duplicate_roots.gltf", doc)
    write(os.path.join(d, "empty.gltf"), b"")


if __name__ == "__main__":
    fixtures()
    malformed_ply()
    malformed_obj()
    malformed_gltf()
    print("wrote fixtures to", FIX, "and malformed files to", MAL)
