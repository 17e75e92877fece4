#!/usr/bin/python3
# Where a render's time goes: the self time of a `perf record` profile of a whole run,
# grouped by what the code does (RESULTS.md, "Where a render's time goes").
#   perf record -F 2000 -o P.data build/tools/pathtracer -q -r 480 360 -l 1 -m 6 -t 2 \
#       --lights=mesh -s 64 -f /tmp/o.exr ../shared/scenes/cs184/CBbunny.dae
#   benchmarks/profile_groups.py P.data
# Groups go by the symbol's name (BSDF code inlined into the integrator loop counts as
# the loop); a symbol that fits no group and holds 0.05 % or more is listed by name.
import re
import subprocess
import sys

GROUPS = [
    ('tracing (the backend\'s traversal and tests)', r'^accel::'),
    ('light sampling (pick, spherical triangles, the emitter guard)',
     r'LightSet::(sample|near_triangle|may_emit_toward|pdf|pick)|SphericalTriangle|barycentrics_toward|triangle_point'),
    ('shadow-ray set-up (error-bound offsets)', r'PathIntegrator::occluded|spawn'),
    ('hit set-up (make_interaction)', r'make_interaction|SceneGeometry::material|mesh_uv'),
    ('camera rays, samplers and the pixel loop',
     r'PixelSample|Camera::generate_ray|renderer::render|SplitMap|start_for|Sampler'),
    ('BSDFs', r'reflectance|bsdf::|Bsdf|Lambert'),
    ('integrator loop', r'PathIntegrator|LightSet::emitted'),
]


def group(dso, sym):
    if dso.startswith('libm'):
        return 'math library (sin, cos, atan2)'
    if dso != 'pathtracer':
        return 'loading, start-up and the save (outside the render clock)'
    for name, pattern in GROUPS:
        if re.search(pattern, sym):
            return name
    if re.search(r'scenes::|load|save|image|oiio|tinygltf|pugi|CLI::', sym, re.I):
        return 'loading, start-up and the save (outside the render clock)'
    return 'other: ' + sym[:70]


def main():
    out = subprocess.run(['perf', 'report', '-i', sys.argv[1], '--no-children', '--sort', 'dso,sym',
                          '--stdio', '-g', 'none'], capture_output=True, text=True, check=True).stdout
    shares = {}
    for line in out.splitlines():
        m = re.match(r'\s*([\d.]+)%\s+(\S+)\s+\[[.k]\]\s+(.*?)\s*$', line)
        if not m:
            continue
        p, g = float(m.group(1)), group(m.group(2), m.group(3))
        if g.startswith('other: ') and p < 0.05:
            g = 'other'
        shares[g] = shares.get(g, 0.0) + p
    for g, p in sorted(shares.items(), key=lambda kv: -kv[1]):
        print(f'{p:6.2f} %  {g}')


if __name__ == '__main__':
    main()
