#!/usr/bin/env python3
"""Writes Cornell boxes for the efficiency goal against Cycles (benchmarks/RESULTS.md,
"Efficiency at equal error") from the course's own files: the two boxes the shared
scenes lack, by giving materials of theirs the CGL elements the course's 3-2 scenes use,
CBgems with the camera matrix the Cycles harness can read, and CBempty lit by its panel
alone. The geometry, the panel and the framing stay the file's.

  copper_bunny  from CBbunny.dae: the bunny (the Default effect) a rough copper
                microfacet conductor, Beckmann alpha 0.5 and copper's eta and k at the
                RGB wavelengths;
  mirror_glass  from CBspheres_lambertian.dae: a mirror sphere on the left and a glass
                one (ior 1.5) on the right, as the course's CBspheres.dae;
  gems_camera   from CBgems.dae: its camera <matrix> has 15 numbers, which the harness's
                parser refuses (a TypeError in Matrix()); the missing one is the 1 of
                the third row, (0 1 0 0): restored, the camera sits at y = 3 looking down
                -y, the view direction our loader rebuilds from the short matrix, so ours
                renders the same bits from either file;
  empty_panel   from CBempty.dae: its one library light is a plain COLLADA <point> (the
                other boxes give the same light a CGL area element), which ours samples
                beside the emissive panel under both light semantics and the harness
                drops ("non-area lights ignored"); without its <instance_light>, the
                panel is the box's only light in both renderers.

  benchmarks/make_boxes.py copper_bunny ../shared/scenes/cs184/CBbunny.dae OUT.dae
  benchmarks/make_boxes.py mirror_glass ../shared/scenes/cs184/CBspheres_lambertian.dae OUT.dae
  benchmarks/make_boxes.py gems_camera ../shared/scenes/cs184/CBgems.dae OUT.dae
  benchmarks/make_boxes.py empty_panel ../shared/scenes/cs184/CBempty.dae OUT.dae
"""
import sys


def cgl(body):
    return f'<extra><technique profile="CGL">{body}</technique></extra>'


# Per kind: the CGL element each named effect gains, and text replaced (each found
# exactly once) as (what the file has, what it gets).
KINDS = {
    'copper_bunny': {'effects': {
        'Default-effect': cgl('<microfacet><alpha>0.5</alpha><eta>0.2004 0.9240 1.1022</eta>'
                              '<k>3.9129 2.4528 2.1422</k></microfacet>'),
    }},
    # The file's "refract" sphere (a Phong surface, effect "glass-effect") becomes glass
    # and its Lambertian one a mirror.
    'mirror_glass': {'effects': {
        'glass-effect': cgl('<glass><reflectance>1 1 1</reflectance><transmittance>1 1 1</transmittance>'
                            '<roughness>0</roughness><ior>1.5</ior></glass>'),
        'lambertian-effect': cgl('<mirror><reflectance>1 1 1</reflectance></mirror>'),
    }},
    'gems_camera': {'replace': [('<matrix sid="transform">-1 0 0 0 0 0 1 3 0 0 0 0 0 0 1</matrix>',
                                 '<matrix sid="transform">-1 0 0 0 0 0 1 3 0 1 0 0 0 0 0 1</matrix>')]},
    'empty_panel': {'replace': [('<instance_light url="#Area-light"/>', '')]},
}


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in KINDS:
        sys.exit(__doc__)
    kind, src, out = sys.argv[1:]
    text = open(src, encoding='utf-8').read()
    for effect, extra in KINDS[kind].get('effects', {}).items():
        start = text.find(f'<effect id="{effect}">')
        end = text.find('</effect>', start)
        if start < 0 or end < 0 or '<extra>' in text[start:end]:
            sys.exit(f'{src}: no plain <effect id="{effect}"> to give {kind}\'s material')
        text = text[:end] + extra + '\n    ' + text[end:]
    for old, new in KINDS[kind].get('replace', []):
        if text.count(old) != 1:
            sys.exit(f'{src}: {kind} expects {old} once, found it {text.count(old)} times')
        text = text.replace(old, new)
    open(out, 'w', encoding='utf-8').write(text)


if __name__ == '__main__':
    main()
