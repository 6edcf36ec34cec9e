"""The picture of the NeuralVolume demo (matplotlib): original | Neural Volume | error on the middle slice, the
figures (time, PSNR, ratio) and the PSNR over the training time."""
import math

import numpy as np

PANEL = 640  # pixels of each rendered view
WIDTH, HEIGHT, DPI = 1920, 1200, 120  # the picture (the CI test checks these dimensions)
BACKGROUND = [0.06, 0.07, 0.09]
_FG, _DIM, _ACCENT = "#e8e8ea", "#9a9ca3", "#ffb347"


def _values(image, name):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    nx, ny, nz = image.GetDimensions()
    return vtk_to_numpy(image.GetPointData().GetArray(name)).astype(np.float64).reshape(nz, ny, nx)


def _column(table, name):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    column = table.GetColumnByName(name)
    return vtk_to_numpy(column).astype(np.float64) if column is not None else np.zeros(0)


def _image_panel(ax, png, title):
    import matplotlib.image as mpimg
    ax.imshow(mpimg.imread(png))
    ax.set_title(title, color=_FG, fontsize=14, pad=8)
    ax.set_axis_off()


def compose(path, original_png, neural_png, source, decoded, training_log, figures):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import gridspec

    from demo_volume import ARRAY
    original = _values(source, ARRAY)
    approx = _values(decoded, ARRAY)
    value_range = float(original.max() - original.min()) or 1.0
    k = original.shape[0] // 2
    error = np.abs(approx[k] - original[k]) / value_range * 100.0  # % of the value range

    bg = tuple(BACKGROUND)
    fig = plt.figure(figsize=(WIDTH / DPI, HEIGHT / DPI), dpi=DPI, facecolor=bg)
    grid = gridspec.GridSpec(2, 3, figure=fig, height_ratios=[1.0, 0.52], left=0.03, right=0.97, top=0.88,
                             bottom=0.07, wspace=0.08, hspace=0.2)
    n = figures["size"]
    raw_mb = n ** 3 * 4 / 1e6
    fig.suptitle("NeuralVolume: a %d\u00b3 Mandelbulb compressed into a neural network" % n, color=_FG,
                 fontsize=20, y=0.975)
    fig.text(0.5, 0.915, "trained in %.0f s (%d steps on the %s)   \u2022   PSNR %.1f dB   \u2022   ratio %.0f:1"
             "  (%.0f MB \u2192 %.2f MB)"
             % (figures["seconds"], figures["steps"], figures["device"], figures["psnr"], figures["ratio"], raw_mb,
                figures["model_bytes"] / 1e6),
             color=_ACCENT, fontsize=15, ha="center", va="center")

    _image_panel(fig.add_subplot(grid[0, 0]), original_png, "Original (ParaView Volume)")
    _image_panel(fig.add_subplot(grid[0, 1]), neural_png, "Neural Volume (the network)")

    ax = fig.add_subplot(grid[0, 2])
    top = max(1.0, float(np.percentile(error, 99.9)))
    shown = ax.imshow(error, origin="lower", cmap="magma", vmin=0.0, vmax=top, interpolation="nearest")
    ax.set_title("|error| on the middle slice (z = %d)" % k, color=_FG, fontsize=14, pad=8)
    ax.set_axis_off()
    bar = fig.colorbar(shown, ax=ax, fraction=0.046, pad=0.02)
    bar.set_label("% of the value range", color=_DIM)
    bar.ax.tick_params(colors=_DIM)
    bar.outline.set_edgecolor(_DIM)

    chart = fig.add_subplot(grid[1, :2], facecolor=bg)
    seconds, psnr = _column(training_log, "ElapsedSeconds"), _column(training_log, "PSNR")
    logged = np.isfinite(psnr)
    chart.plot(seconds[logged], psnr[logged], color=_ACCENT, lw=2, marker="o", ms=3,
               label="PSNR estimate during training (random voxel subset)")
    chart.axhline(figures["psnr"], color="#6fc3ff", lw=1.2, ls="--",
                  label="final PSNR, all %s voxels: %.2f dB" % ("{:,}".format(n ** 3), figures["psnr"]))
    chart.set_xlabel("training time (s)", color=_DIM)
    chart.set_ylabel("PSNR (dB)", color=_DIM)
    chart.set_title("PSNR over the training time", color=_FG, fontsize=14)
    chart.tick_params(colors=_DIM)
    for side in chart.spines.values():
        side.set_color(_DIM)
    chart.grid(color="#2c2f36")
    if logged.any():
        low = math.floor(min(np.min(psnr[logged]), figures["psnr"]) / 5.0) * 5.0
        chart.set_ylim(low, math.ceil(max(np.max(psnr[logged]), figures["psnr"]) / 5.0 + 0.2) * 5.0)
    chart.set_xlim(left=0.0)
    legend = chart.legend(loc="lower right", facecolor=bg, edgecolor=_DIM)
    for text in legend.get_texts():
        text.set_color(_FG)

    notes = fig.add_subplot(grid[1, 2], facecolor=bg)
    notes.set_axis_off()
    lines = [("training time", "%.1f s, %d steps" % (figures["seconds"], figures["steps"])),
             ("device", figures["device"]),
             ("PSNR", "%.2f dB" % figures["psnr"]),
             ("max |error|", "%.1f %% of the range" % (figures["max_difference"] / value_range * 100.0)),
             ("compression ratio", "%.1f : 1" % figures["ratio"]),
             ("field", "%d\u00b3 float32, %.1f MB" % (n, raw_mb)),
             ("network", "%.2f MB (hash grid + MLP, fp16)" % (figures["model_bytes"] / 1e6))]
    for i, (key, value) in enumerate(lines):
        y = 0.92 - i * 0.14
        notes.text(0.02, y, key, color=_DIM, fontsize=13, transform=notes.transAxes, va="center")
        notes.text(0.45, y, value, color=_FG, fontsize=13, transform=notes.transAxes, va="center")

    fig.savefig(path, dpi=DPI, facecolor=bg)
    plt.close(fig)
