"""Every render path and shading mode reaches the engine through the representation and renders its own picture:
each path x mode matches a committed baseline; the engine reports the path it ran and its statistics (samples,
wavefronts of Sample Streaming with its K, accumulated path-tracing frames); the paths agree with each other but
are not identical to the Decode path (identical would mean a fallback); path tracing with and without next-event
estimation render the same picture; empty-space skipping saves samples without
changing the picture; the sample distance and the light direction reach the engine.

Set NV_GENERATE_BASELINE=1 to (re)write the baselines instead of comparing with them."""
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()

from paraview.simple import *  # noqa: E402,F401,F403
import paraview.simple  # noqa: E402

nvtest.load_plugin(globals())
check, log, info = nvtest.check, nvtest.log, nvtest.info
out_dir = nvtest.output_dir()
SIZE = [128, 128]
PATHS = ["Decode", "Sample Streaming", "In-Shader"]
MODES = ["Ray Marching", "Ray Marching + Gradient Shading", "Ray Marching + Shadows", "Path Tracing",
         "Path Tracing + Next-Event Estimation"]
TARGET_SAMPLES = 64  # path tracing: paths per pixel a still render accumulates

BASELINE_DB = 40.0
PATHS_AGREE_DB = 30.0    # the bar: a network path against the Decode path's grid
# Path tracing: the paths' random walks diverge where their field values differ, so their noise differs (a firefly
# in one image is not in the other); the comparison is on 4x4-pixel means (measured at 64 paths per pixel: 38.8 dB
# with next-event estimation raw, 41.9 dB denoised -- the representation's Denoise default, issue 24). Without it, the noisier estimator of the sun's lobe, on 8x8-pixel means (measured
# 35.9 dB; 28.8 dB with the former 5-degree sun disc, found by chance: a pixel was dark or a saturated firefly).
PT_BLOCK = 4
PT_PLAIN_BLOCK, PT_PLAIN_AGREE_DB = 8, 32.0
# Path tracing with and without NEE estimate the same picture (issue 28): on 8x8-pixel means at 64 paths per pixel,
# measured 33.1 dB on each path raw, 39.5-39.8 dB denoised (9.5 dB with the former 5-degree sun: plain path tracing
# was dark with white speckles).
PT_NEE_BLOCK, PT_NEE_AGREE_DB = 8, 30.0
IDENTICAL_DB = 99.0      # above this two images are the same picture (a fallback)
SKIPPING_DB = 45.0       # skipping must not change the picture
DIFFERENT_MAX_DB = 35.0  # a mode that shades differently must show it

paraview.simple._DisableFirstRenderCameraReset()
# Transparent below 65% of the range: empty macrocells for the skipping checks, structure for the shading modes.
wavelet, nc, view, display = nvtest.wavelet_view(SIZE, 0.65)
nvtest.set_camera(view, [55.0, -40.0, 75.0])
display.TargetSamples = TARGET_SAMPLES
display.SamplesPerPixel = 1
display.Ambient = 0.2
display.Diffuse = 0.8
display.Specular = 0.3


def tag(text):
    return text.replace(" + ", "_").replace(" ", "").replace("-", "")


def render(path, mode):
    display.RenderPath = path
    display.ShadingMode = mode
    Render(view)
    png = nvtest.shot(view, os.path.join(out_dir, "paths_%s_%s.png" % (tag(path), tag(mode))), SIZE)
    stats = {name: info(display, name) for name in ("LastRenderPath", "LastSamplesEvaluated", "LastSamplesPlain",
                                                    "LastWavefronts", "LastAccumulatedPaths", "WorkPending")}
    return png, stats


images = {}
for mode in MODES:
    for path in PATHS:
        png, stats = render(path, mode)
        images[(path, mode)] = nvtest.read_png(png)
        label = "%s / %s" % (path, mode)
        log("%s: %r" % (label, stats))
        check(stats["LastRenderPath"] == PATHS.index(path), "%s: the engine ran that path" % label)
        check(stats["LastSamplesEvaluated"] > 0, "%s: samples evaluated" % label)
        check(not nvtest.is_uniform(images[(path, mode)]), "%s: something is drawn" % label)
        check(stats["WorkPending"] == 0, "%s: a still render is final" % label)
        if path == "Sample Streaming":
            check(stats["LastWavefronts"] > 0, "%s: wavefronts reported" % label)
        else:
            check(stats["LastWavefronts"] == 0, "%s: no wavefronts outside Sample Streaming" % label)
        if mode.startswith("Path Tracing"):
            check(stats["LastAccumulatedPaths"] >= TARGET_SAMPLES,
                  "%s: accumulated %d paths of the %d asked" % (label, stats["LastAccumulatedPaths"],
                                                                  TARGET_SAMPLES))
        else:
            check(stats["LastSamplesPlain"] > 0, "%s: plain-marcher samples reported" % label)
        # Plain path tracing: which pixels hold a bright sample is decided by the last bits of the CPU's float
        # rounding (with the former 5-degree sun, on another processor: 6 of 16384 pixels differed, 37.8 dB per
        # pixel, 49.8 dB on 4x4-pixel means). Its baseline is compared on PT_BLOCK-pixel means, as the paths are below.
        block = PT_BLOCK if mode == "Path Tracing" else 1
        nvtest.baseline(png, "TestNeuralVolumePaths_%s_%s" % (tag(path), tag(mode)), BASELINE_DB, label, block)

# --- the paths agree, and the network paths are not the Decode path ------------------------------
block_means = nvtest.block_means


for mode in MODES:
    reference = images[("Decode", mode)]
    for path in PATHS[1:]:
        db = nvtest.image_psnr(images[(path, mode)], reference)
        agree, bar = db, PATHS_AGREE_DB
        if mode.startswith("Path Tracing"):
            block = PT_BLOCK if mode == "Path Tracing + Next-Event Estimation" else PT_PLAIN_BLOCK
            bar = PATHS_AGREE_DB if mode == "Path Tracing + Next-Event Estimation" else PT_PLAIN_AGREE_DB
            agree = nvtest.image_psnr(block_means(images[(path, mode)], block), block_means(reference, block))
        log("%s vs Decode, %s: %.2f dB (compared: %.2f dB)" % (path, mode, db, agree))
        check(agree >= bar, "%s agrees with Decode for %s (%.2f dB < %.1f)" % (path, mode, agree, bar))
        check(db < IDENTICAL_DB, "%s is not the Decode picture for %s (%.2f dB)" % (path, mode, db))

# --- path tracing with and without NEE: the same picture ------------------------------------------------
for path in PATHS:
    db = nvtest.image_psnr(block_means(images[(path, "Path Tracing")], PT_NEE_BLOCK),
                           block_means(images[(path, "Path Tracing + Next-Event Estimation")], PT_NEE_BLOCK))
    log("%s: Path Tracing vs + NEE on %dx%d means: %.2f dB" % (path, PT_NEE_BLOCK, PT_NEE_BLOCK, db))
    check(db >= PT_NEE_AGREE_DB, "%s: Path Tracing and + NEE render the same picture (%.2f dB < %.1f)"
          % (path, db, PT_NEE_AGREE_DB))

# --- each shading mode shades differently ------------------------------------------------------------
plain = images[("Decode", "Ray Marching")]
for mode in MODES[1:]:
    db = nvtest.image_psnr(images[("Decode", mode)], plain)
    check(db < DIFFERENT_MAX_DB, "%s differs from plain ray marching (%.2f dB)" % (mode, db))

# --- path tracing: accumulated while still, no new render once the target is reached ------------
display.RenderPath = "Decode"
display.ShadingMode = "Path Tracing"
Render(view)
renders = info(display, "EngineRenderCount")
Render(view)
check(info(display, "EngineRenderCount") == renders, "a converged path-traced view is not rendered again")
display.TargetSamples = 2 * TARGET_SAMPLES
Render(view)
check(info(display, "LastAccumulatedPaths") >= 2 * TARGET_SAMPLES, "a higher target accumulates further (%d)"
      % info(display, "LastAccumulatedPaths"))
display.TargetSamples = TARGET_SAMPLES

# --- Sample Streaming: K reaches the engine ------------------------------------------------------------
display.ShadingMode = "Ray Marching"
display.RenderPath = "Sample Streaming"
display.StreamingSamples = 2
Render(view)
wavefronts_2 = info(display, "LastWavefronts")
display.StreamingSamples = 16
Render(view)
wavefronts_16 = info(display, "LastWavefronts")
log("wavefronts: K=2 %d, K=16 %d" % (wavefronts_2, wavefronts_16))
check(wavefronts_2 > wavefronts_16 > 0, "fewer wavefronts with a larger K (%d, %d)" % (wavefronts_2, wavefronts_16))

# --- empty-space skipping: fewer samples, same picture ----------------------------------------------
for path in PATHS:
    display.RenderPath = path
    display.EmptySpaceSkipping = 1
    Render(view)
    on = nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, "skip_on.png"), SIZE))
    samples_on, plain_on = info(display, "LastSamplesEvaluated"), info(display, "LastSamplesPlain")
    display.EmptySpaceSkipping = 0
    Render(view)
    off = nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, "skip_off.png"), SIZE))
    samples_off, plain_off = info(display, "LastSamplesEvaluated"), info(display, "LastSamplesPlain")
    db = nvtest.image_psnr(on, off)
    log("%s skipping: %d vs %d samples (plain %d), %.2f dB" % (path, samples_on, samples_off, plain_off, db))
    check(db >= SKIPPING_DB, "%s: skipping does not change the picture (%.2f dB)" % (path, db))
    check(samples_on < samples_off, "%s: skipping evaluates fewer samples (%d vs %d)" % (path, samples_on,
                                                                                         samples_off))
    check(plain_on == plain_off, "%s: the plain-marcher count does not depend on skipping" % path)
display.EmptySpaceSkipping = 1

# --- sample distance -------------------------------------------------------------------------------------
display.RenderPath = "Decode"
Render(view)
default_samples = info(display, "LastSamplesPlain")
default_image = nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, "distance_default.png"), SIZE))
display.SampleDistance = 0.5  # half a voxel of the Wavelet (spacing 1)
Render(view)
half_samples = info(display, "LastSamplesPlain")
ratio = half_samples / float(default_samples)
check(1.8 < ratio < 2.2, "half the sample distance, twice the samples (ratio %.2f)" % ratio)
db = nvtest.image_psnr(nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, "distance_half.png"), SIZE)),
                       default_image)
check(db >= PATHS_AGREE_DB, "a finer sampling renders the same volume (%.2f dB)" % db)
display.SampleDistance = 0.0

# --- light direction: the view's key light or a fixed one ----------------------------------------------
display.ShadingMode = "Ray Marching + Gradient Shading"
Render(view)
follow = nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, "light_view.png"), SIZE))
display.FollowViewLight = 0
display.LightDirection = [0.0, 0.0, -1.0]
Render(view)
below = nvtest.read_png(nvtest.shot(view, os.path.join(out_dir, "light_below.png"), SIZE))
check(nvtest.image_psnr(below, follow) < DIFFERENT_MAX_DB, "a fixed light from below lights differently")
display.FollowViewLight = 1

nvtest.finish()
