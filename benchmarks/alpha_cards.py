#!/usr/bin/env python3
"""Writes a foliage-like test scene for the cost of alpha masking: N leaf cards (quads,
two triangles each) scattered in a 10 x 10 x 10 box with random orientations, over a
ground quad, all sharing one material whose base colour texture is a leaf silhouette
(an ellipse of alpha 255 in a 64 x 64 image of alpha 0, covering about 60 % of the card).

    benchmarks/alpha_cards.py N MODE OUT.gltf     (MODE: OPAQUE, MASK or BLEND)

The same N and seed give the same geometry whatever MODE, so that `accel_bench --scene`
on the MASK and OPAQUE files compares the same rays through the same triangles, filtered
and not. Deterministic (its own seed); images and buffers are data URIs."""
import base64, json, math, random, struct, sys, zlib


def png_rgba(w, h, pixel):
    raw = b"".join(b"\0" + b"".join(struct.pack(">4B", *pixel(x, y)) for x in range(w)) for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def leaf(x, y):
    u, v = (x + 0.5) / 32.0 - 1.0, (y + 0.5) / 32.0 - 1.0
    inside = (u / 0.75) ** 2 + (v / 1.0) ** 2 <= 1.0
    return (60, 140, 40, 255 if inside else 0)


def main():
    n, mode, out = int(sys.argv[1]), sys.argv[2], sys.argv[3]
    rng = random.Random(30)
    pos, uv, idx = [], [], []
    for k in range(n):
        c = [rng.uniform(-5, 5), rng.uniform(0.5, 10.5), rng.uniform(-5, 5)]
        # A random orthonormal pair spanning the card, 0.4 x 0.6 units.
        a = [rng.gauss(0, 1) for _ in range(3)]
        la = math.sqrt(sum(x * x for x in a)) or 1.0
        a = [x / la for x in a]
        b = [rng.gauss(0, 1) for _ in range(3)]
        d = sum(x * y for x, y in zip(a, b))
        b = [y - d * x for x, y in zip(a, b)]
        lb = math.sqrt(sum(x * x for x in b)) or 1.0
        b = [y / lb for y in b]
        base = len(pos)
        for su, sv in [(-1, -1), (1, -1), (1, 1), (-1, 1)]:
            pos.append([c[i] + 0.2 * su * a[i] + 0.3 * sv * b[i] for i in range(3)])
            uv.append([(su + 1) / 2, (sv + 1) / 2])
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    ground = len(pos)
    for p in [(-8, 0, 8), (8, 0, 8), (8, 0, -8), (-8, 0, -8)]:
        pos.append(list(p))
        uv.append([0, 0])
    blob = b"".join(struct.pack("<3f", *p) for p in pos[:ground])
    uv_off = len(blob)
    blob += b"".join(struct.pack("<2f", *t) for t in uv[:ground])
    idx_off = len(blob)
    blob += b"".join(struct.pack("<I", i) for i in idx)
    g_off = len(blob)
    blob += b"".join(struct.pack("<3f", *p) for p in pos[ground:])
    gi_off = len(blob)
    blob += struct.pack("<6I", 0, 1, 2, 0, 2, 3)
    lo = [min(p[i] for p in pos[:ground]) for i in range(3)]
    hi = [max(p[i] for p in pos[:ground]) for i in range(3)]
    material = {"name": "leaf", "doubleSided": True,
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0}}
    if mode != "OPAQUE":
        material["alphaMode"] = mode
    gltf = {
        "asset": {"version": "2.0", "generator": "benchmarks/alpha_cards.py"},
        "buffers": [{"byteLength": len(blob),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": uv_off},
                        {"buffer": 0, "byteOffset": uv_off, "byteLength": idx_off - uv_off},
                        {"buffer": 0, "byteOffset": idx_off, "byteLength": g_off - idx_off},
                        {"buffer": 0, "byteOffset": g_off, "byteLength": gi_off - g_off},
                        {"buffer": 0, "byteOffset": gi_off, "byteLength": 24}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": ground, "type": "VEC3", "min": lo, "max": hi},
                      {"bufferView": 1, "componentType": 5126, "count": ground, "type": "VEC2"},
                      {"bufferView": 2, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
                      {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3",
                       "min": [-8, 0, -8], "max": [8, 0, 8]},
                      {"bufferView": 4, "componentType": 5125, "count": 6, "type": "SCALAR"}],
        "images": [{"uri": "data:image/png;base64," + base64.b64encode(png_rgba(64, 64, leaf)).decode()}],
        "samplers": [{}],
        "textures": [{"source": 0, "sampler": 0}],
        "materials": [material, {"name": "ground", "pbrMetallicRoughness": {"metallicFactor": 0}}],
        "meshes": [{"name": "cards", "primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1},
                                                     "indices": 2, "material": 0}]},
                   {"name": "ground", "primitives": [{"attributes": {"POSITION": 3}, "indices": 4, "material": 1}]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.1, "aspectRatio": 1.333}}],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0}]}},
        "nodes": [{"mesh": 0}, {"mesh": 1},
                  {"camera": 0, "translation": [0, 5.5, 16]},
                  {"extensions": {"KHR_lights_punctual": {"light": 0}},
                   "rotation": [-0.5, 0.1, 0.1, 0.855]}],
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "scene": 0,
    }
    with open(out, "w") as f:
        json.dump(gltf, f)


if __name__ == "__main__":
    main()
