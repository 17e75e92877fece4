#!/usr/bin/env python3
"""Writes the project's own glTF scenes (standard library only):

  scenes/cornell_emissive.gltf   Cornell box lit only by an emissive ceiling panel
  scenes/lights/point.gltf       one small stage per light kind: KHR_lights_punctual
  scenes/lights/directional.gltf   point / directional / spot, an emissive mesh, and
  scenes/lights/spot.gltf          "environment" (no light at all, so the renderer's
  scenes/lights/emissive.gltf      default constant environment lights it)
  scenes/lights/environment.gltf

Geometry lives in one base64 data-URI buffer per file so each scene is a single
self-contained file. Re-run after editing; the outputs are committed.
"""
import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


class Builder:
    def __init__(self):
        self.data = bytearray()
        self.doc = {
            "asset": {"version": "2.0", "generator": "pathtracer scenes/make_gltf_scenes.py"},
            "scene": 0,
            "scenes": [{"nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }

    def _view(self, payload, target):
        while len(self.data) % 4:
            self.data.append(0)
        self.doc["bufferViews"].append(
            {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(payload), "target": target})
        self.data += payload
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, view, ctype, count, typ, **extra):
        acc = {"bufferView": view, "componentType": ctype, "count": count, "type": typ}
        acc.update(extra)
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def material(self, name, albedo=(0.8, 0.8, 0.8), emission=None, strength=None):
        # metallicFactor 0: these are diffuse surfaces, nothing for the loader to replace.
        m = {"name": name,
             "pbrMetallicRoughness": {"baseColorFactor": list(albedo) + [1.0],
                                      "metallicFactor": 0.0, "roughnessFactor": 1.0}}
        if emission is not None:
            m["emissiveFactor"] = list(emission)
        if strength is not None:
            m["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
            self.use_extension("KHR_materials_emissive_strength")
        self.doc["materials"].append(m)
        return len(self.doc["materials"]) - 1

    def mesh(self, name, positions, normals, indices, material):
        pos = b"".join(struct.pack("<3f", *p) for p in positions)
        nrm = b"".join(struct.pack("<3f", *n) for n in normals)
        idx = b"".join(struct.pack("<H", i) for i in indices)
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        a_pos = self._accessor(self._view(pos, 34962), 5126, len(positions), "VEC3", min=lo, max=hi)
        a_nrm = self._accessor(self._view(nrm, 34962), 5126, len(normals), "VEC3")
        a_idx = self._accessor(self._view(idx, 34963), 5123, len(indices), "SCALAR")
        self.doc["meshes"].append({"name": name, "primitives": [
            {"attributes": {"POSITION": a_pos, "NORMAL": a_nrm}, "indices": a_idx,
             "material": material}]})
        return len(self.doc["meshes"]) - 1

    def node(self, name, root=True, **props):
        n = {"name": name}
        n.update(props)
        self.doc["nodes"].append(n)
        idx = len(self.doc["nodes"]) - 1
        if root:
            self.doc["scenes"][0]["nodes"].append(idx)
        return idx

    def use_extension(self, ext):
        used = self.doc.setdefault("extensionsUsed", [])
        if ext not in used:
            used.append(ext)

    def light(self, light):
        self.use_extension("KHR_lights_punctual")
        lights = self.doc.setdefault("extensions", {}).setdefault(
            "KHR_lights_punctual", {"lights": []})["lights"]
        lights.append(light)
        return len(lights) - 1

    def camera(self, name, yfov_deg, aspect, eye, target):
        self.doc.setdefault("cameras", []).append(
            {"name": name, "type": "perspective",
             "perspective": {"yfov": math.radians(yfov_deg), "aspectRatio": aspect,
                             "znear": 0.01, "zfar": 100.0}})
        # A node matrix (column-major), so the loader's matrix path is exercised too.
        return self.node(name, camera=len(self.doc["cameras"]) - 1,
                         matrix=look_at_column_major(eye, target))

    def write(self, path):
        self.doc["buffers"] = [{
            "byteLength": len(self.data),
            "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(self.data)).decode()}]
        doc = {k: v for k, v in self.doc.items() if v != []}
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")
        print("wrote", os.path.relpath(path, HERE))


def sub(a, b): return [a[i] - b[i] for i in range(3)]
def cross(a, b): return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
def norm(a):
    n = math.sqrt(sum(x * x for x in a))
    return [x / n for x in a]


def look_at_column_major(eye, target, up=(0.0, 1.0, 0.0)):
    # Camera looks down local -Z with +Y up.
    f = norm(sub(target, eye))
    r = norm(cross(f, up))
    u = cross(r, f)
    z = [-c for c in f]
    return [r[0], r[1], r[2], 0.0, u[0], u[1], u[2], 0.0, z[0], z[1], z[2], 0.0,
            eye[0], eye[1], eye[2], 1.0]


def quat_from_to(a, b):
    """Unit quaternion (x, y, z, w) rotating unit vector a onto unit vector b."""
    a, b = norm(a), norm(b)
    d = sum(a[i] * b[i] for i in range(3))
    c = cross(a, b)
    if d < -0.999999:  # opposite: any perpendicular axis
        axis = norm(cross([1, 0, 0], a)) if abs(a[0]) < 0.9 else norm(cross([0, 1, 0], a))
        return [axis[0], axis[1], axis[2], 0.0]
    q = [c[0], c[1], c[2], 1.0 + d]
    n = math.sqrt(sum(x * x for x in q))
    return [x / n for x in q]


def quad(p0, p1, p2, p3, normal):
    """Two triangles p0 p1 p2, p0 p2 p3, wound counter-clockwise seen from `normal`."""
    return [p0, p1, p2, p3], [normal] * 4, [0, 1, 2, 0, 2, 3]


def box(half):
    """Axis-aligned box centred at the origin, faces outward, flat normals."""
    hx, hy, hz = half
    faces = [
        ([1, 0, 0], [[hx, -hy, hz], [hx, -hy, -hz], [hx, hy, -hz], [hx, hy, hz]]),
        ([-1, 0, 0], [[-hx, -hy, -hz], [-hx, -hy, hz], [-hx, hy, hz], [-hx, hy, -hz]]),
        ([0, 1, 0], [[-hx, hy, hz], [hx, hy, hz], [hx, hy, -hz], [-hx, hy, -hz]]),
        ([0, -1, 0], [[-hx, -hy, -hz], [hx, -hy, -hz], [hx, -hy, hz], [-hx, -hy, hz]]),
        ([0, 0, 1], [[-hx, -hy, hz], [hx, -hy, hz], [hx, hy, hz], [-hx, hy, hz]]),
        ([0, 0, -1], [[hx, -hy, -hz], [-hx, -hy, -hz], [-hx, hy, -hz], [hx, hy, -hz]]),
    ]
    pos, nrm, idx = [], [], []
    for n, corners in faces:
        base = len(pos)
        pos += corners
        nrm += [n] * 4
        idx += [base + i for i in (0, 1, 2, 0, 2, 3)]
    return pos, nrm, idx


def cornell_emissive():
    b = Builder()
    white = b.material("white", (0.73, 0.73, 0.73))
    red = b.material("red", (0.63, 0.065, 0.05))
    green = b.material("green", (0.14, 0.45, 0.091))
    # Radiance ~ (17, 12, 4) like the classic Cornell light, via emissive strength.
    light = b.material("ceiling light", (0.78, 0.78, 0.78), emission=(1.0, 0.7, 0.25), strength=17.0)
    # Box: x, z in [-1, 1], y in [0, 2]; walls face the interior; the front is open.
    walls = [
        ("floor", white, quad([-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1], [0, 1, 0])),
        ("ceiling", white, quad([-1, 2, -1], [1, 2, -1], [1, 2, 1], [-1, 2, 1], [0, -1, 0])),
        ("back wall", white, quad([-1, 0, -1], [1, 0, -1], [1, 2, -1], [-1, 2, -1], [0, 0, 1])),
        ("left wall", red, quad([-1, 0, 1], [-1, 0, -1], [-1, 2, -1], [-1, 2, 1], [1, 0, 0])),
        ("right wall", green, quad([1, 0, -1], [1, 0, 1], [1, 2, 1], [1, 2, -1], [-1, 0, 0])),
        # The panel hangs just below the ceiling and faces down.
        ("light panel", light, quad([-0.25, 1.98, -0.25], [0.25, 1.98, -0.25], [0.25, 1.98, 0.25],
                                    [-0.25, 1.98, 0.25], [0, -1, 0])),
    ]
    for name, mat, (p, n, i) in walls:
        b.node(name, mesh=b.mesh(name, p, n, i, mat))
    tall = b.mesh("tall block", *box((0.3, 0.6, 0.3)), white)
    short = b.mesh("short block", *box((0.3, 0.3, 0.3)), white)
    b.node("tall block", mesh=tall, translation=[-0.35, 0.6, -0.35],
           rotation=quat_from_to([1, 0, 0], [math.cos(0.3), 0, -math.sin(0.3)]))
    b.node("short block", mesh=short, translation=[0.35, 0.3, 0.3],
           rotation=quat_from_to([1, 0, 0], [math.cos(-0.3), 0, -math.sin(-0.3)]))
    b.camera("camera", 39.0, 1.0, [0.0, 1.0, 3.9], [0.0, 1.0, 0.0])
    b.write(os.path.join(HERE, "cornell_emissive.gltf"))


def light_stage(kind):
    """Floor, a cube and a camera, plus the light named by `kind`."""
    b = Builder()
    grey = b.material("floor", (0.7, 0.7, 0.7))
    orange = b.material("cube", (0.8, 0.4, 0.1))
    b.node("floor", mesh=b.mesh("floor", *quad([-3, 0, 3], [3, 0, 3], [3, 0, -3], [-3, 0, -3], [0, 1, 0]), grey))
    b.node("cube", mesh=b.mesh("cube", *box((0.5, 0.5, 0.5)), orange), translation=[0, 0.5, 0],
           rotation=quat_from_to([1, 0, 0], [math.cos(0.6), 0, -math.sin(0.6)]))
    b.camera("camera", 45.0, 4.0 / 3.0, [0.0, 2.0, 5.0], [0.0, 0.5, 0.0])
    if kind == "point":
        li = b.light({"name": "point", "type": "point", "color": [1.0, 0.95, 0.9], "intensity": 20.0})
        b.node("point light", extensions={"KHR_lights_punctual": {"light": li}}, translation=[1.0, 2.5, 1.0])
    elif kind == "directional":
        li = b.light({"name": "sun", "type": "directional", "color": [1.0, 1.0, 0.95], "intensity": 3.0})
        b.node("sun", extensions={"KHR_lights_punctual": {"light": li}},
               rotation=quat_from_to([0, 0, -1], norm([-0.4, -1.0, -0.6])))
    elif kind == "spot":
        li = b.light({"name": "spot", "type": "spot", "color": [1.0, 1.0, 1.0], "intensity": 40.0,
                      "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.5}})
        b.node("spot light", extensions={"KHR_lights_punctual": {"light": li}}, translation=[0.0, 3.0, 0.0],
               rotation=quat_from_to([0, 0, -1], [0, -1, 0]))
    elif kind == "emissive":
        lamp = b.material("lamp", (0.8, 0.8, 0.8), emission=(1.0, 1.0, 1.0), strength=8.0)
        b.node("lamp", mesh=b.mesh("lamp", *quad([-0.5, 3, -0.5], [0.5, 3, -0.5], [0.5, 3, 0.5],
                                                 [-0.5, 3, 0.5], [0, -1, 0]), lamp))
    elif kind != "environment":
        raise ValueError(kind)
    b.write(os.path.join(HERE, "lights", kind + ".gltf"))


if __name__ == "__main__":
    cornell_emissive()
    for k in ("point", "directional", "spot", "emissive", "environment"):
        light_stage(k)
