"""The volume of the NeuralVolume demo: a Mandelbulb (the power-8 3-D analogue of the Mandelbrot set) computed with
numpy, so that it exists on a fresh machine without any data set.

The value at a point is exp(-d / falloff), d the distance estimate to the fractal surface (0 inside the set): 1 inside,
falling off smoothly outside, so a volume rendering shows the fractal surface and its folds."""
import numpy as np

ARRAY = "Mandelbulb"
HALF_WIDTH = 1.2  # the volume spans [-1.2, 1.2]^3, the bulb's radius is about 1.15


def mandelbulb(n, power=8, iterations=10, bailout=4.0, falloff=0.05):
    """Field of an n^3 grid over [-HALF_WIDTH, HALF_WIDTH]^3 as float32, indexed [z, y, x] (x varies fastest)."""
    axis = np.linspace(-HALF_WIDTH, HALF_WIDTH, n, dtype=np.float32)
    cz, cy, cx = np.meshgrid(axis, axis, axis, indexing="ij")
    c = np.stack([cx.ravel(), cy.ravel(), cz.ravel()])
    del cx, cy, cz
    distance = np.zeros(c.shape[1], np.float32)  # stays 0 for the points that never escape (inside)
    alive = np.arange(c.shape[1])  # points still iterating
    p = c.copy()
    dr = np.ones(c.shape[1], np.float32)  # running derivative |dz/dc|
    for _ in range(iterations):
        r = np.sqrt(np.einsum("ij,ij->j", p, p))
        escaped = r > bailout
        if escaped.any():
            re = r[escaped]
            distance[alive[escaped]] = 0.5 * np.log(re) * re / dr[escaped]
            keep = ~escaped
            alive, p, dr, r = alive[keep], p[:, keep], dr[keep], r[keep]
        r_pow = r ** (power - 1)
        dr = power * r_pow * dr + 1.0
        r_pow *= r
        theta = np.arccos(np.clip(p[2] / np.maximum(r, 1e-20), -1.0, 1.0)) * power
        phi = np.arctan2(p[1], p[0]) * power
        sin_theta = np.sin(theta)
        p = np.stack([r_pow * sin_theta * np.cos(phi), r_pow * sin_theta * np.sin(phi), r_pow * np.cos(theta)])
        p += c[:, alive]
    return np.exp(-distance / falloff).astype(np.float32).reshape(n, n, n)


def spacing(n):
    return 2.0 * HALF_WIDTH / (n - 1)


def fill(image, n):
    """Fills a vtkImageData with the n^3 Mandelbulb (point array ARRAY)."""
    from vtkmodules.util.numpy_support import numpy_to_vtk
    image.SetExtent(0, n - 1, 0, n - 1, 0, n - 1)
    image.SetOrigin(-HALF_WIDTH, -HALF_WIDTH, -HALF_WIDTH)
    image.SetSpacing(spacing(n), spacing(n), spacing(n))
    values = numpy_to_vtk(mandelbulb(n).ravel(), deep=1)
    values.SetName(ARRAY)
    image.GetPointData().SetScalars(values)
