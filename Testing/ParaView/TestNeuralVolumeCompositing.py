"""Neural Volume in a scene: an opaque plane through the volume hides what lies behind it (depth compositing),
perspective and parallel cameras, a camera inside the volume. The references are the same scene without the
plane, the plane alone, and the stock Volume representation of the decoded output (which composites with
opaque geometry itself)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403
import paraview.simple  # noqa: E402

nvtest.load_plugin(globals())
check, log, info = nvtest.check, nvtest.log, nvtest.info
out_dir = nvtest.output_dir()
SIZE = [240, 240]
BACKGROUND = (0.32, 0.34, 0.43)

STOCK_DB = 35.0      # Neural Volume (Decode) vs the stock ray caster on the decoded output: measured 49-58 dB
SAME_DB = 45.0       # a region that must show exactly the reference there
DIFFERENT_MAX_DB = 30.0

paraview.simple._DisableFirstRenderCameraReset()
wavelet, nc = nvtest.wavelet_network()
vmin, vmax = wavelet.PointData["RTData"].GetRange()
view = nvtest.render_view(SIZE, BACKGROUND)
display = nvtest.show_styled(nc, view, "RTData", vmin, vmax)
display.ScalarOpacityUnitDistance = 4.0  # dense enough that the half behind the plane matters


def look_down():
    # Looking down -z at the whole volume (z in [-31, 32]).
    nvtest.set_camera(view, [0.5, 0.5, 260.0], focal=[0.5, 0.5, 0.5], up=[0.0, 1.0, 0.0])


def grow(mask, pixels):
    """The mask dilated by `pixels` (edge pixels of the plane are partly covered)."""
    out = mask.copy()
    for _ in range(pixels):
        grown = out.copy()
        grown[1:, :] |= out[:-1, :]
        grown[:-1, :] |= out[1:, :]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out


def shot(name):
    return nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, name), SIZE))


# An opaque white plane covering the left half (x < 0) of the volume, moved along z.
plane = Plane(Origin=[-45.0, -45.0, 0.0], Point1=[0.0, -45.0, 0.0], Point2=[-45.0, 45.0, 0.0])
plane_display = Show(plane, view)
plane_display.ColorArrayName = ["POINTS", ""]
plane_display.AmbientColor = plane_display.DiffuseColor = [1.0, 1.0, 1.0]
plane_display.Ambient, plane_display.Diffuse = 1.0, 0.0  # flat white, whatever the light


def scene(z, volume="Neural Volume", with_plane=True, with_volume=True):
    plane.Origin = [-45.0, -45.0, z]
    plane.Point1 = [0.0, -45.0, z]
    plane.Point2 = [-45.0, 45.0, z]
    plane_display.Visibility = 1 if with_plane else 0
    display.Visibility = 1 if with_volume else 0
    display.SetRepresentationType(volume)
    look_down()
    Render(view)
    return shot("scene_%s_%s%s%s.png" % (volume.replace(" ", ""), z, "_plane" if with_plane else "",
                                          "_volume" if with_volume else ""))


volume_alone = scene(0.0, with_plane=False)
background = np.all(np.abs(volume_alone - 255.0 * np.array(BACKGROUND)) <= 2.0, axis=2)
check(background.any() and (~background).any(), "the volume covers part of the view")
# Without opaque geometry the depth buffer is not read; the frame's parts add up within the whole.
timings, path = nvtest.info(display, "LastFrameTimings"), nvtest.info(display, "LastDisplayPath")
log("frame timings, volume alone (depth, engine, host copy, upload, draw, total ms): %r; %s" % (timings, path))
check(timings[0] == 0.0 and timings[5] > 0.0 and 0.0 <= timings[1] + timings[3] + timings[4] <= timings[5],
      "volume alone: no depth read, the parts within the frame's %.2f ms" % timings[5])
check(path == "host copy", "the CPU engine's image goes through the host (%s)" % path)

for z, where in ((0.0, "through the middle"), (60.0, "in front"), (-60.0, "behind")):
    plane_alone = scene(z, with_volume=False)
    both = scene(z)
    depth_ms = nvtest.info(display, "LastFrameTimings")[0]
    check(depth_ms > 0.0, "plane %s: the depth of the opaque plane is read (%.3f ms)" % (where, depth_ms))
    stock = scene(z, volume="Volume")
    plane_pixels = np.any(np.abs(plane_alone - 255.0 * np.array(BACKGROUND)) > 2.0, axis=2)
    covered = ~grow(~np.all(plane_alone >= 250.0, axis=2), 2)  # white inside, away from the outline
    uncovered = ~grow(plane_pixels, 2)
    check(covered.sum() > 0.1 * covered.size, "the plane covers a good part of the view")
    db_stock = nvtest.image_psnr(both, stock)
    log("plane %s: neural vs stock %.2f dB" % (where, db_stock))
    check(db_stock >= STOCK_DB, "plane %s: Neural Volume composites like the stock Volume (%.2f dB)"
          % (where, db_stock))
    # Where the plane does not cover the view the volume is alone.
    db_free = nvtest.region_psnr(both, volume_alone, uncovered)
    check(db_free >= SAME_DB, "plane %s: uncovered region = the volume alone (%.2f dB)" % (where, db_free))
    db_plane = nvtest.region_psnr(both, plane_alone, covered)
    db_volume = nvtest.region_psnr(both, volume_alone, covered)
    log("plane %s, covered region: vs plane alone %.2f dB, vs volume alone %.2f dB" % (where, db_plane, db_volume))
    if z > 32.0:
        check(db_plane >= SAME_DB, "a plane in front hides the whole volume (%.2f dB)" % db_plane)
    else:
        check(db_plane < DIFFERENT_MAX_DB, "plane %s: the volume in front of it shows (%.2f dB)" % (where, db_plane))
        check(db_volume < DIFFERENT_MAX_DB, "plane %s: the plane shows through the volume (%.2f dB)"
              % (where, db_volume))
    if z == 0.0:
        # Against the plane behind the whole volume: there the back half of the volume lies over the white plane
        # too; through the middle it is hidden, so the covered region must differ.
        behind_plane = scene(-60.0)
        db_halves = nvtest.region_psnr(both, behind_plane, covered)
        log("covered region, plane through the middle vs behind the volume: %.2f dB" % db_halves)
        check(db_halves < DIFFERENT_MAX_DB, "what lies behind the middle plane is hidden (%.2f dB vs the plane "
              "behind the volume)" % db_halves)

plane_display.Visibility = 0
display.Visibility = 1

# --- parallel projection and a camera inside the volume, against the stock Volume -------------------------
for label, camera in (("parallel", dict(position=[110.0, -80.0, 150.0], parallel=1, scale=60.0)),
                      ("inside", dict(position=[-20.0, -25.0, -10.0], focal=[30.0, 20.0, 25.0], angle=60.0))):
    focal = camera.pop("focal", [0.5, 0.5, 0.5])
    for volume in ("Neural Volume", "Volume"):
        display.SetRepresentationType(volume)
        nvtest.set_camera(view, focal=focal, **camera)
        Render(view)
        shot("%s_%s.png" % (label, volume.replace(" ", "")))
    neural = nvtest.read_png(os.path.join(out_dir, "%s_NeuralVolume.png" % label))
    stock = nvtest.read_png(os.path.join(out_dir, "%s_Volume.png" % label))
    check(not nvtest.is_uniform(neural), "%s: something is drawn" % label)
    db = nvtest.image_psnr(neural, stock)
    log("%s: neural vs stock %.2f dB" % (label, db))
    check(db >= STOCK_DB, "%s camera: Neural Volume matches the stock Volume (%.2f dB)" % (label, db))

nvtest.finish()
