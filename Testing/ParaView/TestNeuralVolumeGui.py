"""The ParaView GUI refines a Neural Volume picture without blocking: runs NeuralVolumeGuiScript.py in the paraview
executable, built-in and connected to a loopback pvserver (see that script); and NeuralCompressOnlineGuiScript.py:
background training shown live in the GUI."""
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

nvtest.require_display()
check, log = nvtest.check, nvtest.log
import shutil  # noqa: E402


def executable(name):
    local = os.path.join(os.path.dirname(sys.executable), name)
    return local if os.path.exists(local) else shutil.which(name)


paraview, pvserver = executable("paraview"), executable("pvserver")
if not paraview or not pvserver:
    nvtest.skip("no paraview/pvserver executable found")
script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "NeuralVolumeGuiScript.py")


def run_gui(label, extra_args, env_extra, gui_script=script):
    env = dict(os.environ)
    env.update(env_extra)
    env["NV_TEST_DIR"] = os.path.dirname(os.path.abspath(__file__))
    log("--- GUI, %s" % label)
    try:
        result = subprocess.run([paraview, "--dr", "--script=" + gui_script] + extra_args, env=env, timeout=120,
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    except subprocess.TimeoutExpired as e:
        log((e.stdout or b"").decode(errors="replace"))
        return check(False, "%s: the GUI finished in time" % label)
    log(result.stdout.decode(errors="replace"))
    return check(result.returncode == 0, "%s: every check in the GUI passed (exit code %d)"
                 % (label, result.returncode))


for stale in ("builtin_first", "builtin_final", "remote_first", "remote_final"):
    path = os.path.join(nvtest.output_dir(), "gui_%s.png" % stale)
    if os.path.exists(path):
        os.remove(path)
run_gui("built-in session", [], {})
# Neural Compress trains in the background while the GUI shows it (the live-source timer, Stop Training).
run_gui("online training", [], {},
        os.path.join(os.path.dirname(os.path.abspath(__file__)), "NeuralCompressOnlineGuiScript.py"))

with nvtest.pvserver(pvserver, "gui_pvserver.log") as (server, port):
    run_gui("client-server session", ["--server-url=cs://127.0.0.1:%d" % port], {"NV_GUI_REMOTE": "1"})

# The refreshed picture is not the first frame. (The two sessions' pictures are not compared: the GUI sizes its
# views itself, and a capture at another size restarts the accumulation.)
out = nvtest.output_dir()
images = {name: os.path.join(out, "gui_%s.png" % name) for name in
          ("builtin_first", "builtin_final", "remote_first", "remote_final")}
if all(check(os.path.exists(p), "%s written" % p) for p in images.values()):
    for session in ("builtin", "remote"):
        db = nvtest.image_psnr(nvtest.read_png(images[session + "_final"]), nvtest.read_png(images[session + "_first"]))
        log("%s: final vs first frame %.2f dB" % (session, db))
        check(db < 45.0, "%s: the accumulated picture is not the first frame (%.2f dB)" % (session, db))
nvtest.finish()
