#!/usr/bin/env python3
"""Writes unlit_panel.gltf beside this script (tests/gltf/gltf_unlit_test.cpp reads it).

A white diffuse floor (y = 0), an upright panel (z = -1, facing the camera) whose
material requires KHR_materials_unlit with base colour (0.9, 0.5, 0.2), a point light
above and in front, and a camera at (0, 1, 4) looking down -Z. Buffers are data URIs, so
the file stands alone."""
import base64, json, os, struct

def quad(corners):
    pos = b"".join(struct.pack("<3f", *c) for c in corners)
    idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    return pos, idx

floor = quad([(-3, 0, 3), (3, 0, 3), (3, 0, -3), (-3, 0, -3)])        # ccw seen from +Y
panel = quad([(-1, 0.2, -1), (1, 0.2, -1), (1, 1.8, -1), (-1, 1.8, -1)])  # ccw seen from +Z
blob = floor[0] + floor[1] + panel[0] + panel[1]
views, accessors, off = [], [], 0
for pos, idx, lo, hi in [(floor[0], floor[1], [-3, 0, -3], [3, 0, 3]),
                         (panel[0], panel[1], [-1, 0.2, -1], [1, 1.8, -1])]:
    views.append({"buffer": 0, "byteOffset": off, "byteLength": len(pos)})
    accessors.append({"bufferView": len(views) - 1, "componentType": 5126, "count": 4, "type": "VEC3",
                      "min": lo, "max": hi})
    off += len(pos)
    views.append({"buffer": 0, "byteOffset": off, "byteLength": len(idx)})
    accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": 6, "type": "SCALAR"})
    off += len(idx)

gltf = {
    "asset": {"version": "2.0", "generator": "tests/gltf/data/make_unlit.py"},
    "extensionsUsed": ["KHR_materials_unlit", "KHR_lights_punctual"],
    "extensionsRequired": ["KHR_materials_unlit"],
    "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 40.0}]}},
    "buffers": [{"byteLength": len(blob),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    "bufferViews": views,
    "accessors": accessors,
    "materials": [
        {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1],
                                                   "metallicFactor": 0, "roughnessFactor": 1}},
        # The fallback a viewer without the extension would show (the spec's advice), and
        # an emission that unlit must ignore.
        {"name": "unlit", "doubleSided": True, "emissiveFactor": [1, 1, 1],
         "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.5, 0.2, 1], "metallicFactor": 0,
                                  "roughnessFactor": 0.9},
         "extensions": {"KHR_materials_unlit": {}}},
    ],
    "meshes": [
        {"name": "floor", "primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]},
        {"name": "panel", "primitives": [{"attributes": {"POSITION": 2}, "indices": 3, "material": 1}]},
    ],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.0, "znear": 0.01}}],
    "nodes": [
        {"name": "floor", "mesh": 0},
        {"name": "panel", "mesh": 1},
        {"name": "light", "translation": [0, 3, 1], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        {"name": "camera", "camera": 0, "translation": [0, 1, 4]},
    ],
    "scenes": [{"nodes": [0, 1, 2, 3]}],
    "scene": 0,
}
here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "unlit_panel.gltf"), "w") as f:
    json.dump(gltf, f, indent=1)
    f.write("\n")
