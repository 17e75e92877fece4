# Are two renders the same expected image? Region means of luminance over a G x G grid
# (and the whole image), each with its standard error from the EXR's 'variance' channel
# (the variance of each pixel's mean), compared by z = (a - b) / sqrt(se_a^2 + se_b^2).
#   /usr/bin/python3 benchmarks/region_check.py A.exr B.exr [G=8]
# Prints the worst |z|, how many regions exceed 3, and the whole-image ratio. For a
# low-discrepancy render the per-pixel variance overstates its error: z is conservative.
import OpenImageIO as oiio, numpy as np, sys


def load(p):
    b = oiio.ImageBuf(p); spec = b.spec(); names = list(spec.channelnames)
    a = b.get_pixels(oiio.FLOAT).reshape(spec.height, spec.width, spec.nchannels)
    lum = 0.2126 * a[..., names.index('R')] + 0.7152 * a[..., names.index('G')] + 0.0722 * a[..., names.index('B')]
    return lum.astype(np.float64), a[..., names.index('variance')].astype(np.float64)


def regions(lum, var, g):
    h, w = lum.shape
    out = []
    for j in range(g):
        for i in range(g):
            sl = (slice(j * h // g, (j + 1) * h // g), slice(i * w // g, (i + 1) * w // g))
            n = lum[sl].size
            out.append((lum[sl].mean(), np.sqrt(var[sl].sum()) / n))
    out.append((lum.mean(), np.sqrt(var.sum()) / lum.size))
    return out


a, b = load(sys.argv[1]), load(sys.argv[2])
g = int(sys.argv[3]) if len(sys.argv) > 3 else 8
ra, rb = regions(*a, g), regions(*b, g)
z = [(x[0] - y[0]) / max(np.hypot(x[1], y[1]), 1e-12) for x, y in zip(ra, rb)]
zr = np.abs(z[:-1])
print(f'regions {len(zr)}: max |z| {zr.max():.2f}, |z| > 3: {int((zr > 3).sum())}, |z| > 2: {int((zr > 2).sum())}; '
      f'whole image {rb[-1][0] / ra[-1][0] - 1:+.4%} (z {z[-1]:+.2f}, se {100 * np.hypot(ra[-1][1], rb[-1][1]) / ra[-1][0]:.3f}%)')
k = int(np.argmax(zr))
print(f'  worst region {k} (row {k // g}, column {k % g}): {ra[k][0]:.5f} +- {ra[k][1]:.5f} vs {rb[k][0]:.5f} +- {rb[k][1]:.5f}')
