#!/usr/bin/env python3
"""Writes scenes/cornell.dae, the project's default scene.

It is a Cornell box in the CS184 COLLADA dialect (see ../shared/scenes/README.md) so the
default render goes through exactly the loader path the course files use: CGL spheres,
a CGL area light in library_lights plus an emissive panel mesh at the same place (the
course's boxes carry both), polylists with per-corner normals, a Blender-like camera.

Conventions chosen here:
  * Z_UP (as the course files): floor at z = 0, ceiling at z = H.
  * The open side faces -Y; the camera sits on -Y looking along +Y.
  * Wall normals point INTO the box and each triangle is wound so that its geometric
    normal agrees with the stored normal (unlike the course files, which wind outward);
    renderers then see the same side whichever normal they use.

Run: python3 scenes/make_cornell_dae.py  (rewrites scenes/cornell.dae and
scenes/cornell_materials.dae next to this file). cornell_materials.dae is the same box
with the CS184 3-2 BSDFs: a mirror sphere, a glass sphere and a gold microfacet sphere.
It also writes scenes/mis_veach.dae, Veach's MIS scene in the same dialect (see MIS_WALLS).
"""
import os

# Box: 2.1 wide (x), 2.1 deep (y), 1.7 high (z).
X0, X1 = -1.05, 1.05
Y0, Y1 = -1.05, 1.05  # Y0 is the open front
H = 1.7
LIGHT_Z = H - 0.01     # just below the ceiling
LIGHT_W, LIGHT_D = 0.5, 0.4  # along x, along y
LIGHT_RADIANCE = 12.0

MATERIALS = {
    # name: (diffuse rgb, CGL emission radiance or None)
    "white": ((0.73, 0.73, 0.73), None),
    "red": ((0.63, 0.065, 0.05), None),
    "green": ((0.14, 0.45, 0.091), None),
    "sphere_white": ((0.8, 0.8, 0.8), None),
    "sphere_blue": ((0.2, 0.35, 0.75), None),
    "light": ((0.8, 0.8, 0.8), (LIGHT_RADIANCE,) * 3),
}


def quad(name, corners, normal, material):
    """Two triangles (0,1,2) (0,2,3); corners are listed counter-clockwise seen from the
    side the normal points to, so the winding matches the normal."""
    return dict(name=name, corners=corners, normal=normal, material=material)


WALLS = [
    quad("floor", [(X0, Y0, 0), (X1, Y0, 0), (X1, Y1, 0), (X0, Y1, 0)], (0, 0, 1), "white"),
    quad("ceiling", [(X0, Y0, H), (X0, Y1, H), (X1, Y1, H), (X1, Y0, H)], (0, 0, -1), "white"),
    quad("backWall", [(X0, Y1, 0), (X1, Y1, 0), (X1, Y1, H), (X0, Y1, H)], (0, -1, 0), "white"),
    quad("leftWall", [(X0, Y0, 0), (X0, Y1, 0), (X0, Y1, H), (X0, Y0, H)], (1, 0, 0), "red"),
    quad("rightWall", [(X1, Y0, 0), (X1, Y0, H), (X1, Y1, H), (X1, Y1, 0)], (-1, 0, 0), "green"),
    quad("lightPanel",
         [(-LIGHT_W / 2, -LIGHT_D / 2, LIGHT_Z), (-LIGHT_W / 2, LIGHT_D / 2, LIGHT_Z),
          (LIGHT_W / 2, LIGHT_D / 2, LIGHT_Z), (LIGHT_W / 2, -LIGHT_D / 2, LIGHT_Z)],
         (0, 0, -1), "light"),
]

SPHERES = [
    # name, centre (resting on the floor: z = radius), radius, material
    ("sphereWhite", (-0.45, 0.35, 0.38), 0.38, "sphere_white"),
    ("sphereBlue", (0.5, -0.3, 0.3), 0.3, "sphere_blue"),
]

# Camera on the open side, looking along +y with +z up: local X -> +x, Y -> +z, Z -> -y.
# At z = 0 like the course's Cornell boxes: the course framing looks along the camera
# transform applied to (0,0,-1) *with* translation, so a camera at the box's mid-height
# would tilt that view down onto the outside of the ceiling.
CAMERA_POS = (0.0, -4.3, 0.0)
AREA_LIGHT = True
DESCRIPTION = "The project's default scene: a Cornell box in the CS184 COLLADA dialect, Z_UP."


def fmt(v):
    return " ".join(f"{x:g}" for x in v)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def sub(a, b):
    return tuple(x - y for x, y in zip(a, b))


def dot(a, b):
    return sum(x * y for x, y in zip(a, b))


# CS184 3-2 BSDF elements (the CGL collada parser's names) for cornell_materials.dae.
CGL_BSDFS = {
    "mirror": "<mirror><reflectance>0.95 0.95 0.95</reflectance></mirror>",
    "glass": "<glass><reflectance>1 1 1</reflectance><transmittance>1 1 1</transmittance>"
             "<roughness>0</roughness><ior>1.5</ior></glass>",
    # Gold (eta, k at ~ 614, 549, 466 nm), as the course's example gold.
    "gold": "<microfacet><alpha>0.2</alpha><eta>0.21646 0.42833 1.3284</eta>"
            "<k>3.2390 2.4599 1.8661</k></microfacet>",
}
MATERIAL_SPHERES = [
    ("sphereMirror", (-0.45, 0.35, 0.38), 0.38, "mirror"),
    ("sphereGlass", (0.45, -0.3, 0.3), 0.3, "glass"),
    ("sphereGold", (0.05, 0.75, 0.2), 0.2, "gold"),
]


def effect(name, rgb, emission):
    extra = ""
    bsdf = CGL_BSDFS.get(name)
    if emission:
        bsdf = f"""<emission>
            <radiance>{fmt(emission)}</radiance>
          </emission>"""
    if bsdf:
        extra = f"""
      <extra>
        <technique profile="CGL">
          {bsdf}
        </technique>
      </extra>"""
    return f"""
    <effect id="{name}-effect">
      <profile_COMMON>
        <technique sid="common">
          <lambert>
            <diffuse>
              <color sid="diffuse">{fmt(rgb)} 1</color>
            </diffuse>
          </lambert>
        </technique>
      </profile_COMMON>{extra}
    </effect>"""


def mesh_geometry(w):
    n = w["name"]
    c = w["corners"]
    # The stored normal must agree with the winding; fail loudly if the table is wrong.
    assert dot(cross(sub(c[1], c[0]), sub(c[2], c[0])), w["normal"]) > 0, n
    pos = " ".join(fmt(p) for p in c)
    return f"""
    <geometry id="{n}-mesh" name="{n}">
      <mesh>
        <source id="{n}-positions">
          <float_array id="{n}-positions-array" count="12">{pos}</float_array>
          <technique_common>
            <accessor source="#{n}-positions-array" count="4" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <source id="{n}-normals">
          <float_array id="{n}-normals-array" count="3">{fmt(w["normal"])}</float_array>
          <technique_common>
            <accessor source="#{n}-normals-array" count="1" stride="3">
              <param name="X" type="float"/>
              <param name="Y" type="float"/>
              <param name="Z" type="float"/>
            </accessor>
          </technique_common>
        </source>
        <vertices id="{n}-vertices">
          <input semantic="POSITION" source="#{n}-positions"/>
        </vertices>
        <polylist material="{w["material"]}-material" count="2">
          <input semantic="VERTEX" source="#{n}-vertices" offset="0"/>
          <input semantic="NORMAL" source="#{n}-normals" offset="1"/>
          <vcount>3 3</vcount>
          <p>0 0 1 0 2 0 0 0 2 0 3 0</p>
        </polylist>
      </mesh>
    </geometry>"""


def sphere_geometry(name, radius):
    return f"""
    <geometry id="{name}-data" name="{name}">
      <extra>
        <technique profile="CGL">
          <sphere>
            <radius>{radius:g}</radius>
          </sphere>
        </technique>
      </extra>
    </geometry>"""


def matrix(rows):
    return " ".join(fmt(r) for r in rows)


def instance(node, geom_url, material):
    return f"""
      <node id="{node}" name="{node}" type="NODE">
        <matrix sid="transform">{matrix([(1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)])}</matrix>
        <instance_geometry url="#{geom_url}">
          <bind_material>
            <technique_common>
              <instance_material symbol="{material}-material" target="#{material}-material"/>
            </technique_common>
          </bind_material>
        </instance_geometry>
      </node>"""


def write(filename, spheres, materials_table, walls=None, area_light=True):
    global SPHERES, MATERIALS, WALLS, AREA_LIGHT
    SPHERES, MATERIALS, AREA_LIGHT = spheres, materials_table, area_light
    if walls is not None:
        WALLS = walls
    doc = document()
    out = os.path.join(os.path.dirname(os.path.abspath(__file__)), filename)
    with open(out, "w") as f:
        f.write(doc)


def main():
    write("cornell.dae", SPHERES, MATERIALS)
    mats = dict(MATERIALS)
    for _, _, _, m in MATERIAL_SPHERES:
        mats[m] = ((0.8, 0.8, 0.8), None)
    write("cornell_materials.dae", MATERIAL_SPHERES, mats)
    global DESCRIPTION
    DESCRIPTION = ("Veach's MIS scene, one glossy floor and three spherical lights of equal power, "
                   "in the CS184 COLLADA dialect, Z_UP.")
    write("mis_veach.dae", MIS_SPHERES, MIS_MATERIALS, MIS_WALLS, area_light=False)


# mis_veach.dae: Veach's multiple-importance-sampling scene (Veach 1997, fig. 9.2) reduced
# to one glossy floor. Three spherical lights of radius 0.03, 0.12 and 0.45 and equal power
# (radiance ~ 1/r^2) hang above a rough aluminium floor (Beckmann alpha 0.08) in front of a
# dark diffuse wall. Light sampling serves the small light, BSDF sampling the large one;
# benchmarks/mis_equal_time.sh renders it with --lights=mesh (the spheres are the lights;
# there is no library light) and --cam-pos 0 -4 1.2 --cam-target 0 0.6 0.3.
MIS_WALLS = [
    quad("floor", [(-4, -5, 0), (4, -5, 0), (4, 3, 0), (-4, 3, 0)], (0, 0, 1), "glossy"),
    quad("backWall", [(-4, 3, 0), (4, 3, 0), (4, 3, 3), (-4, 3, 3)], (0, -1, 0), "dark"),
]
MIS_SPHERES = [
    ("lightSmall", (-1.3, 1.5, 0.9), 0.03, "light_small"),
    ("lightMedium", (0.0, 1.5, 0.9), 0.12, "light_medium"),
    ("lightLarge", (1.4, 1.5, 0.9), 0.45, "light_large"),
]
MIS_MATERIALS = {
    "glossy": ((0.8, 0.8, 0.8), None),
    "dark": ((0.2, 0.2, 0.2), None),
    "light_small": ((0.8, 0.8, 0.8), (900.0, 540.0, 270.0)),
    "light_medium": ((0.8, 0.8, 0.8), (25.0, 62.5, 31.0)),
    "light_large": ((0.8, 0.8, 0.8), (2.2, 3.3, 4.4)),
}
CGL_BSDFS["glossy"] = ("<microfacet><alpha>0.08</alpha><eta>1.6574 0.8803 0.5212</eta>"
                       "<k>9.2238 6.2695 4.8370</k></microfacet>")


def document():
    effects = "".join(effect(n, rgb, em) for n, (rgb, em) in MATERIALS.items())
    materials = "".join(
        f"""
    <material id="{n}-material" name="{n}">
      <instance_effect url="#{n}-effect"/>
    </material>""" for n in MATERIALS)
    geometries = "".join(mesh_geometry(w) for w in WALLS)
    geometries += "".join(sphere_geometry(n, r) for n, _, r, _ in SPHERES)

    nodes = ""
    # Area light: a LIGHT_W x LIGHT_D rectangle facing -z; its size is the node's scale
    # (x: LIGHT_W along local -x edge, y: LIGHT_D along the local +y edge).
    light_m = [(LIGHT_W, 0, 0, 0), (0, LIGHT_D, 0, 0), (0, 0, 1, LIGHT_Z), (0, 0, 0, 1)]
    if AREA_LIGHT:
        nodes += f"""
      <node id="AreaLight" name="AreaLight" type="NODE">
        <matrix sid="transform">{matrix(light_m)}</matrix>
        <instance_light url="#AreaLight-light"/>
      </node>"""
    cam_m = [(1, 0, 0, CAMERA_POS[0]), (0, 0, -1, CAMERA_POS[1]), (0, 1, 0, CAMERA_POS[2]),
             (0, 0, 0, 1)]
    nodes += f"""
      <node id="Camera" name="Camera" type="NODE">
        <matrix sid="transform">{matrix(cam_m)}</matrix>
        <instance_camera url="#Camera-camera"/>
      </node>"""
    for w in WALLS:
        nodes += instance(w["name"], w["name"] + "-mesh", w["material"])
    for name, centre, _, mat in SPHERES:
        m = [(1, 0, 0, centre[0]), (0, 1, 0, centre[1]), (0, 0, 1, centre[2]), (0, 0, 0, 1)]
        nodes += f"""
      <node id="{name}" name="{name}" type="NODE">
        <matrix sid="transform">{matrix(m)}</matrix>
        <instance_geometry url="#{name}-data">
          <bind_material>
            <technique_common>
              <instance_material symbol="{mat}-material" target="#{mat}-material"/>
            </technique_common>
          </bind_material>
        </instance_geometry>
      </node>"""

    lights = f"""  <library_lights>
    <light id="AreaLight-light" name="AreaLight">
      <technique_common>
        <point>
          <color sid="color">{fmt((LIGHT_RADIANCE,) * 3)}</color>
        </point>
      </technique_common>
      <extra>
        <technique profile="CGL">
          <area>
            <color sid="color">{fmt((LIGHT_RADIANCE,) * 3)}</color>
          </area>
        </technique>
      </extra>
    </light>
  </library_lights>
""" if AREA_LIGHT else ""
    doc = f"""<?xml version="1.0" encoding="utf-8"?>
<!-- Generated by scenes/make_cornell_dae.py; edit that script, not this file.
     {DESCRIPTION} -->
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset>
    <contributor>
      <authoring_tool>scenes/make_cornell_dae.py</authoring_tool>
    </contributor>
    <unit name="meter" meter="1"/>
    <up_axis>Z_UP</up_axis>
  </asset>
{lights}  <library_cameras>
    <camera id="Camera-camera" name="Camera">
      <optics>
        <technique_common>
          <perspective>
            <xfov sid="xfov">49.13434</xfov>
            <aspect_ratio>1.333333</aspect_ratio>
            <znear sid="znear">0.1</znear>
            <zfar sid="zfar">100</zfar>
          </perspective>
        </technique_common>
      </optics>
    </camera>
  </library_cameras>
  <library_effects>{effects}
  </library_effects>
  <library_materials>{materials}
  </library_materials>
  <library_geometries>{geometries}
  </library_geometries>
  <library_visual_scenes>
    <visual_scene id="Scene" name="Scene">{nodes}
    </visual_scene>
  </library_visual_scenes>
  <scene>
    <instance_visual_scene url="#Scene"/>
  </scene>
</COLLADA>
"""
    return doc


if __name__ == "__main__":
    main()
