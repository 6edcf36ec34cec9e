"""The GUI answers input while Neural Compress trains on the CPU and while the Neural Volume renders by Sample
Streaming and In-Shader on the CPU: runs GuiLatencyScript.py in the real paraview executable (xdotool drags the
mouse over the view; median input latency <= 0.2 s, largest <= 0.5 s, in each phase), and the Apply of a 2^21-entry
table returns within 0.1 s, the GUI answering while that network is made and trained."""
import json
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()
check, log = nvtest.check, nvtest.log
paraview = os.path.join(os.path.dirname(sys.executable), "paraview")
paraview = paraview if os.path.exists(paraview) else shutil.which("paraview")
if not paraview or not shutil.which("xdotool"):
    nvtest.skip("no paraview executable or no xdotool")
here = os.path.dirname(os.path.abspath(__file__))
result_path = os.path.join(nvtest.output_dir(), "gui_latency.json")
if os.path.exists(result_path):
    os.remove(result_path)
env = dict(os.environ, NV_TEST_DIR=here)
try:
    run = subprocess.run([paraview, "--dr", "--script=" + os.path.join(here, "GuiLatencyScript.py")], env=env,
                         timeout=400, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    log(run.stdout.decode(errors="replace"))
    check(run.returncode == 0, "every check in the GUI passed (exit code %d)" % run.returncode)
except subprocess.TimeoutExpired as e:
    log((e.stdout or b"").decode(errors="replace"))
    check(False, "the GUI finished in time")
if check(os.path.exists(result_path), "the GUI wrote its figures"):
    with open(result_path) as f:
        figures = json.load(f)
    phases = ["watching", "training", "Sample Streaming", "In-Shader", "large table apply", "large table"]
    check(sorted(figures) == sorted(phases), "every phase measured: %r" % sorted(figures))
nvtest.finish()
