#!/usr/bin/env python3
"""Writes alpha_quads.gltf beside this script (tests/gltf/gltf_alpha_test.cpp reads it).

Five unit quads in the plane y = 0 (facing +Y, uv = ((x - x0) / 2, (z + 1) / 2)), side by
side along x, one per material, to cover glTF 2.0's alphaMode (spec section 3.9.4):

  0 opaque        no alphaMode (OPAQUE), baseColorFactor alpha 0.3, which OPAQUE ignores
  1 mask_default  MASK, no alphaCutoff (0.5), base colour texture with a 4x4 checker of
                  alpha 0 / 255
  2 mask_cutoff   MASK, alphaCutoff 0.25, baseColorFactor alpha 0.8, the checker texture
  3 blend         BLEND, baseColorFactor alpha 0.5, an alphaCutoff that BLEND ignores
  4 mask_opaque   MASK, a base colour texture whose alpha is 255 everywhere

Images and buffers are data URIs, so the file stands alone."""
import base64, json, os, struct, sys

# One PNG writer for the alpha scenes: benchmarks/alpha_cards.py's.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "benchmarks"))
from alpha_cards import png_rgba  # noqa: E402


def uri(data, mime):
    return "data:%s;base64,%s" % (mime, base64.b64encode(data).decode())


checker = png_rgba(4, 4, lambda x, y: (200, 180, 160, 255 if (x + y) % 2 else 0))
opaque = png_rgba(2, 2, lambda x, y: (120, 200, 80, 255))

blob = b""
views, accessors, meshes = [], [], []
for k in range(5):
    x0 = 3.0 * k - 1.0
    pos = struct.pack("<12f", x0, 0, 1, x0 + 2, 0, 1, x0 + 2, 0, -1, x0, 0, -1)  # ccw seen from +Y
    uv = struct.pack("<8f", 0, 1, 1, 1, 1, 0, 0, 0)
    idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    for data, acc in [(pos, {"componentType": 5126, "count": 4, "type": "VEC3",
                             "min": [x0, 0, -1], "max": [x0 + 2, 0, 1]}),
                      (uv, {"componentType": 5126, "count": 4, "type": "VEC2"}),
                      (idx, {"componentType": 5123, "count": 6, "type": "SCALAR"})]:
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        acc["bufferView"] = len(views) - 1
        accessors.append(acc)
        blob += data
        blob += b"\0" * (-len(blob) % 4)
    a = 3 * k
    meshes.append({"name": "quad%d" % k,
                   "primitives": [{"attributes": {"POSITION": a, "TEXCOORD_0": a + 1}, "indices": a + 2,
                                   "material": k}]})

gltf = {
    "asset": {"version": "2.0", "generator": "tests/gltf/data/make_alpha.py"},
    "buffers": [{"byteLength": len(blob), "uri": uri(blob, "application/octet-stream")}],
    "bufferViews": views,
    "accessors": accessors,
    "images": [{"uri": uri(checker, "image/png")}, {"uri": uri(opaque, "image/png")}],
    "samplers": [{}],
    "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}],
    "materials": [
        {"name": "opaque", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 0.3],
                                                    "metallicFactor": 0}},
        {"name": "mask_default", "alphaMode": "MASK",
         "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0}},
        {"name": "mask_cutoff", "alphaMode": "MASK", "alphaCutoff": 0.25,
         "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.8], "baseColorTexture": {"index": 0},
                                  "metallicFactor": 0}},
        {"name": "blend", "alphaMode": "BLEND", "alphaCutoff": 0.9,
         "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.6, 0.7, 0.5], "metallicFactor": 0}},
        {"name": "mask_opaque", "alphaMode": "MASK",
         "pbrMetallicRoughness": {"baseColorTexture": {"index": 1}, "metallicFactor": 0}},
    ],
    "meshes": meshes,
    "nodes": [{"mesh": k} for k in range(5)],
    "scenes": [{"nodes": list(range(5))}],
    "scene": 0,
}
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "alpha_quads.gltf")
with open(out, "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
