#!/usr/bin/env python3
"""Writes the "rough copper bunny" box of #31's efficiency table: the course's CBbunny.dae
with the bunny's material (the Default effect) made a CGL microfacet conductor, as the
course's 3-2 scenes write one: Beckmann alpha 0.5 and copper's eta and k at the RGB
wavelengths. The walls, the panel and the framing stay the file's.

  benchmarks/make_copper_bunny.py ../shared/scenes/cs184/CBbunny.dae OUT.dae
"""
import sys

COPPER = ('<extra><technique profile="CGL"><microfacet><alpha>0.5</alpha>'
          '<eta>0.2004 0.9240 1.1022</eta><k>3.9129 2.4528 2.1422</k>'
          '</microfacet></technique></extra>')


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    src, out = sys.argv[1], sys.argv[2]
    text = open(src, encoding='utf-8').read()
    start = text.find('<effect id="Default-effect">')
    end = text.find('</effect>', start)
    if start < 0 or end < 0 or '<extra>' in text[start:end]:
        sys.exit(f'{src}: no plain <effect id="Default-effect"> (the bunny\'s material) to make copper')
    open(out, 'w', encoding='utf-8').write(text[:end] + COPPER + '\n    ' + text[end:])


if __name__ == '__main__':
    main()
