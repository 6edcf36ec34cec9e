"""The Neural Compress panel in the real GUI: runs NeuralCompressPanelGuiScript.py in the paraview executable (a filter
created by Quick Launch and applied by the panel, typed by xdotool): one training chart per filter, the render view
stays active, the Training Status line follows the background training. Screenshots: gui_panel_*.png."""
import os
import shutil
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()
check, log = nvtest.check, nvtest.log
local = os.path.join(os.path.dirname(sys.executable), "paraview")
paraview = local if os.path.exists(local) else shutil.which("paraview")
if not paraview or not shutil.which("xdotool") or not shutil.which("import"):
    nvtest.skip("needs paraview, xdotool and ImageMagick's import")
env = dict(os.environ, NV_TEST_DIR=os.path.dirname(os.path.abspath(__file__)))
script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "NeuralCompressPanelGuiScript.py")
try:
    result = subprocess.run([paraview, "--dr", "--script=" + script], env=env, timeout=150,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    log(result.stdout.decode(errors="replace"))
    check(result.returncode == 0, "every check in the GUI passed (exit code %d)" % result.returncode)
except subprocess.TimeoutExpired as e:
    log((e.stdout or b"").decode(errors="replace"))
    check(False, "the GUI finished in time")
nvtest.finish()
