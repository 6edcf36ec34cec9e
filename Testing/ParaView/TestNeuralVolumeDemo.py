"""The first run (Testing/demo.py, command 1 of the README's quick start): compresses the 256^3 Mandelbulb, renders
it with ParaView's Volume and with the Neural Volume, and writes one picture. Checks the picture (dimensions, the two
renderings show the same shape), the printed figures against stated thresholds, and that the log holds no error or
warning line and at most one line about the GPU (the plain CPU fallback message)."""
import json
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402

check, log = nvtest.check, nvtest.log
nvtest.require_display()

# Measured on a loaded 2-core machine (the demo's 60 s budget): with the default Automatic storage (an automatic size
# coded in 8 bits) 1525 steps, PSNR 44.5 dB, ratio 25.3:1 (a 2^17 table); with Float16 (before) 660-680 steps, 40.6-40.8
# dB, 36.6:1 (2^15). The ratio must reach the demo's target (20:1); on an idle machine more steps fit in the budget
# and the PSNR is higher; the margin covers a CI machine running other tests at the same time.
PSNR_MIN = 37.0
RATIO_MIN = 20.0
SHAPE_IOU_MIN = 0.88  # overlap of the Mandelbulb's footprint in the two renderings (measured 0.944)
WIDTH, HEIGHT = 1920, 1200  # Testing/demo_picture.py
BUDGET = 60.0

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
out = nvtest.output_dir()
picture = os.path.join(out, "demo.png")
panels = os.path.join(out, "demo-panels")
for stale in (picture, os.path.join(panels, "original.png"), os.path.join(panels, "neural.png")):
    if os.path.exists(stale):
        os.remove(stale)
pvbatch = os.environ.get("NV_PVBATCH", "pvbatch")
command = [pvbatch, "--force-offscreen-rendering", os.path.join(root, "demo.py"), nvtest.plugin_path(), picture,
           "--panels", panels]
log("running " + " ".join(command))
run = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=540)
text = run.stdout.decode("utf-8", "replace")
with open(os.path.join(out, "demo.log"), "w") as f:
    f.write(text)
log(text)
check(run.returncode == 0, "demo.py exits with 0 (got %d)" % run.returncode)

# --- the figures -----------------------------------------------------------------------------------------------------
lines = text.splitlines()
found = [line for line in lines if line.startswith("demo figures: ")]
check(len(found) == 1, "one 'demo figures:' line")
figures = json.loads(found[-1][len("demo figures: "):]) if found else {}
log("figures: %r" % figures)
psnr, ratio = figures.get("psnr", 0.0), figures.get("ratio", 0.0)
check(figures.get("size") == 256, "the demo compresses a 256^3 volume")
check(psnr >= PSNR_MIN, "PSNR %.2f dB >= %.1f dB" % (psnr, PSNR_MIN))
check(ratio >= RATIO_MIN, "compression ratio %.1f >= %.1f" % (ratio, RATIO_MIN))
check(figures.get("steps", 0) > 0, "trained some steps")
check(0.0 < figures.get("seconds", 0.0) <= 1.1 * BUDGET, "training time %r s within the %g s budget"
      % (figures.get("seconds"), BUDGET))
check(figures.get("max_difference", 1e9) < 1.0, "max |difference| %r below the value range (1)"
      % figures.get("max_difference"))
check(("demo: %d steps in" % figures.get("steps", -1)) in text and ("PSNR %.2f dB" % psnr) in text,
      "the figures are printed for the user")

# --- the log: no error or warning line, at most one line about the GPU ---------------------------------------------
# "max error" is a figure of the filter's summary line, not an error.
bad = [line for line in lines
       if re.search(r"error|warn|traceback|fatl|abort|segmentation|cuda[a-z]*err", line.replace("max error", ""),
                    re.IGNORECASE)]
check(not bad, "no error or warning line in the demo's log: %r" % bad)
gpu_lines = [line for line in lines if re.search(r"gpu|cuda|driver", line, re.IGNORECASE)]
if figures.get("device") == "CPU":  # a machine without a usable GPU (CI): one plain message about it
    check(len(gpu_lines) <= 1, "at most one line about the GPU: %r" % gpu_lines)
    check(all("no GPU usable" in line for line in gpu_lines), "the plain CPU fallback message: %r" % gpu_lines)

# --- the picture -----------------------------------------------------------------------------------------------------
check(os.path.exists(picture), "picture %s written" % picture)
if os.path.exists(picture):
    pixels = nvtest.read_png(picture)
    check(pixels.shape[:2] == (HEIGHT, WIDTH), "picture is %dx%d (got %r)" % (WIDTH, HEIGHT, pixels.shape[:2]))
    check(float(pixels.std()) > 10.0, "picture is not blank (std %.1f)" % float(pixels.std()))
original_png, neural_png = os.path.join(panels, "original.png"), os.path.join(panels, "neural.png")
if check(os.path.exists(original_png) and os.path.exists(neural_png), "panel renderings kept in %s" % panels):
    original, neural = nvtest.read_png(original_png), nvtest.read_png(neural_png)
    background = original[0, 0]
    covered = np.abs(original - background).max(axis=2) > 30
    check(covered.mean() > 0.15, "the Mandelbulb fills %.0f%% of the original panel" % (100 * covered.mean()))
    drawn = np.abs(neural - background).max(axis=2) > 30
    iou = float((covered & drawn).sum()) / max(1, int((covered | drawn).sum()))
    log("footprint overlap of the Neural Volume and the ParaView Volume renderings: %.3f" % iou)
    check(iou >= SHAPE_IOU_MIN, "the Neural Volume draws the original's shape: overlap %.3f >= %.2f"
          % (iou, SHAPE_IOU_MIN))

nvtest.finish()
