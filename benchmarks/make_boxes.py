#!/usr/bin/env python3
"""Writes the two Cornell boxes of the efficiency goal against Cycles that the shared
scenes lack (benchmarks/RESULTS.md, "Efficiency at equal error"), from the course's own
files, by giving materials of theirs the CGL elements the course's 3-2 scenes use. The
geometry, the panel and the framing stay the file's.

  copper_bunny  from CBbunny.dae: the bunny (the Default effect) a rough copper
                microfacet conductor, Beckmann alpha 0.5 and copper's eta and k at the
                RGB wavelengths;
  mirror_glass  from CBspheres_lambertian.dae: a mirror sphere on the left and a glass
                one (ior 1.5) on the right, as the course's CBspheres.dae.

  benchmarks/make_boxes.py copper_bunny ../shared/scenes/cs184/CBbunny.dae OUT.dae
  benchmarks/make_boxes.py mirror_glass ../shared/scenes/cs184/CBspheres_lambertian.dae OUT.dae
"""
import sys


def cgl(body):
    return f'<extra><technique profile="CGL">{body}</technique></extra>'


KINDS = {
    'copper_bunny': {
        'Default-effect': cgl('<microfacet><alpha>0.5</alpha><eta>0.2004 0.9240 1.1022</eta>'
                              '<k>3.9129 2.4528 2.1422</k></microfacet>'),
    },
    # The file's "refract" sphere (a Phong surface, effect "glass-effect") becomes glass
    # and its Lambertian one a mirror.
    'mirror_glass': {
        'glass-effect': cgl('<glass><reflectance>1 1 1</reflectance><transmittance>1 1 1</transmittance>'
                            '<roughness>0</roughness><ior>1.5</ior></glass>'),
        'lambertian-effect': cgl('<mirror><reflectance>1 1 1</reflectance></mirror>'),
    },
}


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in KINDS:
        sys.exit(__doc__)
    kind, src, out = sys.argv[1:]
    text = open(src, encoding='utf-8').read()
    for effect, extra in KINDS[kind].items():
        start = text.find(f'<effect id="{effect}">')
        end = text.find('</effect>', start)
        if start < 0 or end < 0 or '<extra>' in text[start:end]:
            sys.exit(f'{src}: no plain <effect id="{effect}"> to give {kind}\'s material')
        text = text[:end] + extra + '\n    ' + text[end:]
    open(out, 'w', encoding='utf-8').write(text)


if __name__ == '__main__':
    main()
