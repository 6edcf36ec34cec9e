"""Runs inside the ParaView GUI (paraview --script=..., started by TestNeuralCompressPanelGui.py). Neural Compress is
created the way a user does (Quick Launch: ctrl+space, "Neural Compress", Enter; typed by xdotool) and applied by the
Properties panel (Auto Apply), so ParaView's own Apply opens the outputs in their preferred views. Checks: one
training chart per filter, the render view stays the active view, and the panel's Training Status follows the
background training without any script call. Writes screenshots of the whole screen (NV_TEST_OUTPUT). Exits the GUI
with 0 when every check passed, 1 otherwise."""
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.environ["NV_TEST_DIR"])  # the GUI runs this script without __file__
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403

check, log = nvtest.check, nvtest.log
nvtest.load_plugin(globals(), scripted=False)
GetSettingsProxy("GeneralSettings").AutoApply = 1
wavelet = Wavelet(WholeExtent=[-23, 24] * 3)
render_view = GetActiveViewOrCreate("RenderView")
Show(wavelet, render_view)
Render(render_view)
SetActiveSource(wavelet)


def quick_launch(name):
    """Types Quick Launch's shortcut and the filter's name into the GUI (a background process: the event loop runs)."""
    script = ("sleep 1; xdotool key Escape; xdotool search --sync --onlyvisible --name 'ParaView' windowsize 1280 1000; "
              "xdotool search --sync --onlyvisible --name 'ParaView' windowfocus --sync; "
              "xdotool key ctrl+space; sleep 1; xdotool type --delay 60 '%s'; sleep 1; xdotool key Return" % name)
    return subprocess.Popen(["sh", "-c", script])


def screenshot(name):
    path = os.path.join(nvtest.output_dir(), name)
    subprocess.run(["import", "-window", "root", path], timeout=30)
    log("screenshot: " + path)


def compress_filters():
    return [p for p in GetSources().values() if p.SMProxy.GetXMLName() == "NeuralCompress"]


def charts():
    return [v for v in GetViews() if v.SMProxy.GetXMLName() == "XYChartView"]


def status_of(proxy):
    """The value the panel shows: the property as it is (no UpdatePropertyInformation here)."""
    text = proxy.GetPropertyValue("TrainingStatus") or ""
    match = re.match(r"(\w+): (\d+)/(\d+) steps, PSNR", text)
    return (match.group(1), int(match.group(2)), text) if match else (text, -1, text)


phase = {"name": "first", "since": time.time(), "samples": []}
typing = [quick_launch("Neural Compress")]


@nvtest.fail_on_exception
def on_timer(caller, event):
    now = time.time()
    filters = compress_filters()
    if phase["name"] == "first":
        if len(filters) == 1 and filters[0].GetPropertyValue("TrainingStatus"):
            phase.update(name="watch", since=now)
        elif now - phase["since"] > 40:
            check(False, "Quick Launch created and applied Neural Compress (%d filters)" % len(filters))
            nvtest.finish()
            nvtest._exit(1)
    elif phase["name"] == "watch":
        phase["samples"].append((now, status_of(filters[0])))
        if now - phase["since"] > 6.0:
            active = GetActiveView()
            log("after the first Apply: %d chart(s), active view %s, status samples %r"
                % (len(charts()), active.SMProxy.GetXMLName() if active else None,
                   [s[1][2] for s in phase["samples"][::10]]))
            check(len(charts()) == 1, "the first filter's Apply opens one training chart (%d)" % len(charts()))
            check(active is not None and active.SMProxy.GetXMLName() == "RenderView",
                  "the render view stays the active view (%s)" % (active.SMProxy.GetXMLName() if active else None))
            training = [s for s in phase["samples"] if s[1][0] == "Training"]
            check(len(training) >= 2 and training[-1][1][1] > training[0][1][1],
                  "the panel's Training Status follows the training without a script call (%r -> %r)"
                  % (training[0][1][2] if training else None, training[-1][1][2] if training else None))
            check(all(" s left" in s[1][2] for s in training), "the status line says the time left while training")
            screenshot("gui_panel_first.png")
            filters[0].StopTraining()  # a GUI busy training on 2 cores can drop typed keys (issue 28, item 1)
            SetActiveSource(wavelet)
            typing.append(quick_launch("Neural Compress"))
            phase.update(name="second", since=time.time())
    elif phase["name"] == "second":
        if len(filters) == 2 and all(f.GetPropertyValue("TrainingStatus") for f in filters):
            phase.update(name="settle", since=now)
        elif now - phase["since"] > 20 and len(typing) == 2 and len(filters) == 1:
            log("the typed keys were lost; Quick Launch once more")
            SetActiveSource(wavelet)
            typing.append(quick_launch("Neural Compress"))
        elif now - phase["since"] > 45:
            check(False, "the second Neural Compress was created and applied (%d filters)" % len(filters))
            nvtest.finish()
            nvtest._exit(1)
    elif phase["name"] == "settle" and now - phase["since"] > 3.0:
        active = GetActiveView()
        log("after the second Apply: %d chart(s), active view %s"
            % (len(charts()), active.SMProxy.GetXMLName() if active else None))
        check(len(charts()) == 2, "one training chart per filter (%d for 2 filters)" % len(charts()))
        check(active is not None and active.SMProxy.GetXMLName() == "RenderView",
              "the render view is still the active view (%s)" % (active.SMProxy.GetXMLName() if active else None))
        for f in filters:
            f.StopTraining()
        screenshot("gui_panel_second.png")
        nvtest.finish()
        nvtest._exit(1 if nvtest._failures else 0)


interactor = render_view.GetInteractor()
interactor.AddObserver("TimerEvent", on_timer)
interactor.CreateRepeatingTimer(100)
