#!/usr/bin/env python3
"""Writes textured_quad.gltf, the glTF fuzz target's seed for the texture path: one quad
whose material reads every texture slot we decode (base colour with alpha, emissive,
metallic-roughness, normal, transmission), from tiny embedded PNGs of odd sizes and both
bit depths, through samplers of every wrap and magnification filter, with RGBA vertex
colours (COLOR_0, normalized bytes), so that mutations start inside image decoding,
MIP-pyramid building, sampler and vertex-colour reading.

    tests/fuzz/seeds/make_textured_seed.py > tests/fuzz/seeds/textured_quad.gltf
"""
import base64
import json
import struct
import sys
import zlib


def png(w, h, channels, depth, pixel):
    """A PNG of w x h, `channels` per pixel (1 grey, 3 RGB, 4 RGBA), 8 or 16 bits."""
    colour = {1: 0, 3: 2, 4: 6}[channels]
    raw = b''
    for y in range(h):
        raw += b'\0' + b''.join(
            struct.pack('>' + ('B' if depth == 8 else 'H') * channels, *pixel(x, y)) for x in range(w))

    def chunk(kind, data):
        return struct.pack('>I', len(data)) + kind + data + struct.pack('>I', zlib.crc32(kind + data))

    return (b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', struct.pack('>IIBBBBB', w, h, depth, colour, 0, 0, 0)) +
            chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b''))


def uri(data, mime):
    return 'data:%s;base64,%s' % (mime, base64.b64encode(data).decode())


images = [
    png(5, 3, 4, 8, lambda x, y: (40 * x, 80 * y, 200, 255 if (x + y) % 2 else 128)),  # base colour, alpha
    png(4, 4, 3, 16, lambda x, y: (0, 16000 * x, 60000 - 9000 * y)),                    # metallic-roughness
    png(3, 7, 3, 8, lambda x, y: (128 + 20 * x, 128 - 10 * y, 255)),                     # normal
    png(2, 2, 1, 8, lambda x, y: (255 * x,)),                                            # transmission (grey)
    png(1, 1, 3, 8, lambda x, y: (255, 200, 100)),                                       # emissive
]
pos = struct.pack('<12f', -1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0)
uv = struct.pack('<8f', 0, 0, 2, 0, 2, 2, 0, 2)
idx = struct.pack('<6H', 0, 1, 2, 0, 2, 3)
col = struct.pack('<16B', 255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 0, 255, 255, 255, 255)
buf = pos + uv + idx + b'\0\0' + col
gltf = {
    'asset': {'version': '2.0'},
    'extensionsUsed': ['KHR_texture_transform', 'KHR_materials_transmission'],
    'scene': 0, 'scenes': [{'nodes': [0]}], 'nodes': [{'mesh': 0}],
    'meshes': [{'primitives': [{'attributes': {'POSITION': 0, 'TEXCOORD_0': 1, 'COLOR_0': 3}, 'indices': 2, 'material': 0}]}],
    'materials': [{
        'pbrMetallicRoughness': {
            'baseColorTexture': {'index': 0, 'extensions': {'KHR_texture_transform': {'scale': [2, 1], 'rotation': 0.5}}},
            'metallicRoughnessTexture': {'index': 1}},
        'normalTexture': {'index': 2, 'scale': 0.5},
        'emissiveTexture': {'index': 4}, 'emissiveFactor': [1, 1, 1],
        'alphaMode': 'MASK',
        'extensions': {'KHR_materials_transmission': {'transmissionFactor': 0.5, 'transmissionTexture': {'index': 3}}}}],
    'textures': [{'source': i, 'sampler': i % 3} for i in range(len(images))],
    'samplers': [{'wrapS': 10497, 'wrapT': 33648}, {'wrapS': 33071, 'magFilter': 9728}, {'wrapT': 33071}],
    'images': [{'uri': uri(d, 'image/png')} for d in images],
    'buffers': [{'byteLength': len(buf), 'uri': uri(buf, 'application/octet-stream')}],
    'bufferViews': [{'buffer': 0, 'byteOffset': 0, 'byteLength': 48}, {'buffer': 0, 'byteOffset': 48, 'byteLength': 32},
                    {'buffer': 0, 'byteOffset': 80, 'byteLength': 12}, {'buffer': 0, 'byteOffset': 94, 'byteLength': 16}],
    'accessors': [
        {'bufferView': 0, 'componentType': 5126, 'count': 4, 'type': 'VEC3', 'min': [-1, -1, 0], 'max': [1, 1, 0]},
        {'bufferView': 1, 'componentType': 5126, 'count': 4, 'type': 'VEC2'},
        {'bufferView': 2, 'componentType': 5123, 'count': 6, 'type': 'SCALAR'},
        {'bufferView': 3, 'componentType': 5121, 'count': 4, 'type': 'VEC4', 'normalized': True}],
}
json.dump(gltf, sys.stdout, indent=1)
sys.stdout.write('\n')
