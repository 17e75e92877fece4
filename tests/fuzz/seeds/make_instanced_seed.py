#!/usr/bin/env python3
"""Writes instanced_cubes.gltf, the glTF fuzz target's seed for EXT_mesh_gpu_instancing:
a cube placed four times by float TRANSLATION and SCALE and a normalized 16-bit ROTATION,
so that mutations start inside the per-instance accessors and their count checks.

    tests/fuzz/seeds/make_instanced_seed.py > tests/fuzz/seeds/instanced_cubes.gltf
"""
import base64
import json
import math
import struct
import sys

corners = [(x, y, z) for z in (0, 1) for y in (0, 1) for x in (0, 1)]
faces = [0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5]
n = 4
translation = [(3.0 * i, 0.0, 0.0) for i in range(n)]
rotation = [(0.0, math.sin(0.3 * i), 0.0, math.cos(0.3 * i)) for i in range(n)]
scale = [(1.0, 1.0 + i, 0.5) for i in range(n)]

data = b''.join(struct.pack('<3f', *c) for c in corners)
data += struct.pack('<%dH' % len(faces), *faces)
views = [(0, len(data) - 2 * len(faces)), (len(data) - 2 * len(faces), 2 * len(faces))]
for values, fmt in ((translation, '<3f'), (rotation, '<4h'), (scale, '<3f')):
    start = len(data)
    for v in values:
        data += struct.pack(fmt, *(round(c * 32767) if fmt == '<4h' else c for c in v))
    views.append((start, len(data) - start))

gltf = {
    'asset': {'version': '2.0'},
    'extensionsUsed': ['EXT_mesh_gpu_instancing', 'KHR_mesh_quantization'],
    'scene': 0,
    'scenes': [{'nodes': [0]}],
    'nodes': [{'mesh': 0, 'extensions': {'EXT_mesh_gpu_instancing': {
        'attributes': {'TRANSLATION': 2, 'ROTATION': 3, 'SCALE': 4}}}}],
    'meshes': [{'primitives': [{'attributes': {'POSITION': 0}, 'indices': 1}]}],
    'accessors': [
        {'bufferView': 0, 'componentType': 5126, 'count': 8, 'type': 'VEC3', 'min': [0, 0, 0], 'max': [1, 1, 1]},
        {'bufferView': 1, 'componentType': 5123, 'count': len(faces), 'type': 'SCALAR'},
        {'bufferView': 2, 'componentType': 5126, 'count': n, 'type': 'VEC3'},
        {'bufferView': 3, 'componentType': 5122, 'normalized': True, 'count': n, 'type': 'VEC4'},
        {'bufferView': 4, 'componentType': 5126, 'count': n, 'type': 'VEC3'},
    ],
    'bufferViews': [{'buffer': 0, 'byteOffset': o, 'byteLength': l} for o, l in views],
    'buffers': [{'byteLength': len(data),
                 'uri': 'data:application/octet-stream;base64,' + base64.b64encode(data).decode()}],
}
json.dump(gltf, sys.stdout, indent=1)
sys.stdout.write('\n')
