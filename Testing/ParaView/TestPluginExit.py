"""A pvbatch that used the plugin (Neural Compress filters, one deleted, one still training, a Neural Volume in a
render view) ends normally, with exit status 0, never a signal (issue 29: nv.pv.NeuralCompressTimeSeries once ended
in SIGSEGV after its checks).

The plugin's client-side helpers (vtkNeuralVolumeProxyObserver, vtkNeuralVolumeRefreshDriver) are statics destroyed
when the process exits, after ParaView has deleted its proxies without telling them (no UnRegisterEvent). They used to
remove their observers from those deleted proxies: a use after free that crashed only when the freed memory had been
reused. Here each child runs with glibc's MALLOC_PERTURB_, which fills freed memory with a byte pattern, so that such
a use crashes every time (it did: SIGSEGV in vtkObject::RemoveObserver from the helpers' destructors, 4 of 4 runs).
"""
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

RUNS = 2
CHILD_SECONDS = 240.0
DONE = "plugin exit child: pipeline done"


def child():
    """Builds what a session leaves behind, then ends the script normally (pvbatch tears ParaView down and exits)."""
    source = Wavelet(WholeExtent=[-11, 12] * 3)
    small = dict(SelectInputScalars=["POINTS", "RTData"], BatchSize=4096, Levels=8, FeaturesPerLevel=2,
                 NetworkWidth=16, HiddenLayers=1, Threads=2, TimeBudget=0)
    shown = NeuralCompress(Input=source, TrainingSteps=60, **small)
    shown.UpdatePipeline()
    shown.WaitForTraining()
    shown.UpdatePipeline()
    view = CreateView("RenderView")
    view.ViewSize = [200, 160]
    display = Show(shown, view)
    display.SetRepresentationType("Neural Volume")
    Render(view)
    deleted = NeuralCompress(Input=source, TrainingSteps=20, **small)
    deleted.UpdatePipeline()
    deleted.WaitForTraining()
    Delete(deleted)
    training = NeuralCompress(Input=source, TrainingSteps=1000000, **small)  # still training at the exit
    training.UpdatePipeline()
    nvtest.log(DONE)
    sys.stdout.flush()


def run_child(index):
    """One child under MALLOC_PERTURB_: (exit status or signal text, log text)."""
    env = dict(os.environ, NV_EXIT_CHILD="1", MALLOC_PERTURB_="165")
    command = [os.environ.get("NV_PVBATCH", "pvbatch"), "--force-offscreen-rendering", os.path.abspath(__file__)]
    log_path = os.path.join(nvtest.output_dir(), "plugin_exit_%d.log" % index)
    with open(log_path, "w") as log_file:
        process = subprocess.Popen(command, env=env, stdout=log_file, stderr=subprocess.STDOUT)
        try:
            code = process.wait(timeout=CHILD_SECONDS)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
            code = "hung"
    with open(log_path) as f:
        text = f.read()
    status = "signal %d" % -code if isinstance(code, int) and code < 0 else code
    return status, text


def main():
    nvtest.require_display()
    for index in range(RUNS):
        started = time.time()
        status, text = run_child(index)
        log("run %d: exit status %r after %.1f s" % (index, status, time.time() - started))
        check(DONE in text, "run %d: the child built its pipeline" % index)
        check(status == 0, "run %d: pvbatch ended normally with status 0, not %r (log: %s)"
              % (index, status, text[-2000:].replace("\n", " | ")))


check, log = nvtest.check, nvtest.log
if os.environ.get("NV_EXIT_CHILD"):
    from paraview.simple import *  # noqa: E402,F401,F403
    nvtest.load_plugin(globals(), scripted=False)
    child()  # the script then ends normally
else:
    main()
    nvtest.finish()
