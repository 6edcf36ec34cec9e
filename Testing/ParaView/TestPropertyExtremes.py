"""Every property of Neural Compress and of the Neural Volume representation driven to its extremes gives an error
message or a result, never a signal or a hang.

The properties are listed from the XML files (Filters/Compress/NeuralCompress.xml, Representations/
NeuralVolumeRepresentation.xml.in), so a property added there is covered without touching this test. Each one is set,
alone, on a small base configuration (a 16^3 Wavelet, a tiny network, TimeBudget 2 s) to 0, -1, INT_MIN and INT_MAX
(integers; every element of a vector, and [v, 1, 1]), to 0, -1, +-1e308, +-inf, NaN and the smallest subnormal
(doubles), to empty, garbage and 100 kB strings, and the commands run before, during and after a training. The values
are written raw into the server-manager properties (past the XML domains), as a script or a state file can.

The cases run in worker pvbatch processes, a batch of cases each; a worker that dies (a signal) or runs past its time
fails the case it was in, and the next worker goes on after it. Besides "no crash", the cases named in issue 13 check
their outcome: the memory estimate that refuses a huge table and a huge decoded output, the DecodeResolution clamp,
the time budget held by a capped BatchSize, and a long decode aborted through the algorithm's abort flag.
"""
import json
import math
import os
import subprocess
import sys
import time
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
INT_MIN, INT_MAX = -2 ** 31, 2 ** 31 - 1
INTS = [0, -1, INT_MIN, INT_MAX]
DOUBLES = [0.0, -1.0, -1e308, 1e308, math.inf, -math.inf, math.nan, 5e-324]
STRINGS = ["", "\x01garbage;;:", "nvnet1;0123456789abcdef:!!!!", "x" * 100000]
VALUE_TAGS = ("IntVectorProperty", "IdTypeVectorProperty", "DoubleVectorProperty", "StringVectorProperty")
WORKER_SECONDS = 240  # a worker running longer than this hangs: its current case fails
# The base configuration of every filter case: trains in well under a second.
FILTER_BASE = dict(TrainInBackground=0, OutputMode=2, TrainingSteps=3, TimeBudget=2.0, BatchSize=4096, Levels=8,
                   FeaturesPerLevel=2, NetworkWidth=16, HiddenLayers=1, Threads=2, PSNRInterval=0)
BACKGROUND = (0.1, 0.1, 0.1)
COMMANDS = ("PauseTraining", "ResumeTraining", "StopTraining", "ContinueTraining", "FastForward", "DecodeNow",
            "WaitForTraining")


def xml_properties(path, proxy_tag):
    """(name, tag, elements) of the settable properties of the first `proxy_tag` of an XML file."""
    proxy = next(ET.parse(path).getroot().iter(proxy_tag))
    result = []
    for child in proxy:
        if child.tag not in VALUE_TAGS + ("Property",) or child.get("information_only") == "1":
            continue
        result.append((child.get("name"), child.tag, int(child.get("number_of_elements", "1"))))
    return result


def value_cases(name, tag, elements):
    """Extreme values of one property: lists of elements."""
    if tag == "StringVectorProperty":
        if name == "SelectInputScalars":
            return [["0", "0", "0", "0", "NoSuchArray"], ["0", "0", "0", "1", "RTData"], ["0", "0", "0", "99", ""]]
        return [[s] * elements for s in STRINGS]
    values = DOUBLES if tag == "DoubleVectorProperty" else INTS
    cases = [[v] * elements for v in values]
    if elements == 3:
        cases += [[v, 1, 1] for v in values if not (isinstance(v, float) and math.isnan(v)) and v != 0]
    return cases


def memory_bytes():
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) * 1024
    return 0


def filter_cases():
    cases = []
    for name, tag, elements in xml_properties(os.path.join(ROOT, "Filters", "Compress", "NeuralCompress.xml"), "SourceProxy"):
        if tag == "Property":
            for when in ("before", "after", "background"):
                cases.append(dict(kind="command", command=name, when=when))
            continue
        for values in value_cases(name, tag, elements):
            cases.append(dict(kind="filter", set={name: values}))
    # Issue 13's cases, with the outcome they must have.
    gib = memory_bytes() / 2.0 ** 30
    # 1.5e9 parameters (below the engine's 2^31), about 59 GB to train: refused below 74 GB of memory.
    huge = dict(kind="filter", label="a 2^26 table on 31 levels",
                set={"Log2TableSize": [26], "Levels": [31], "FeaturesPerLevel": [1], "FinestResolution": [2 ** 20]})
    if gib < 70:
        huge["expect"] = "of host memory"
    cases.append(huge)
    if gib < 29:  # 23.8 GB estimated: refused below 29.7 GB of memory (80%)
        cases.append(dict(kind="filter", label="Log2TableSize 24, FinestResolution 4096",
                          set={"Log2TableSize": [24], "FinestResolution": [4096], "Levels": [16],
                               "FeaturesPerLevel": [4], "NetworkWidth": [64]},
                          expect="of host memory"))
    if gib < 42:  # 34.4 GB estimated
        # With a network fine enough for it (the default one of a 16^3 input resolves 64 samples per axis at most).
        cases.append(dict(kind="filter", label="OutputResolution 2048^3", set={"OutputResolution": [2048] * 3,
                                                                              "FinestResolution": [4096]},
                          expect="the decoded output needs about"))
    cases.append(dict(kind="filter", label="OutputResolution 2^31-1 x 2^31-1 x 1",
                      set={"OutputResolution": [INT_MAX, INT_MAX, 1]}, expect="is finer than the network resolves"))
    cases.append(dict(kind="filter", label="BatchSize 2^24 with a 5 s TimeBudget", input=32, budget=5.0,
                      set={"BatchSize": [2 ** 24], "TimeBudget": [5.0], "TrainingSteps": [1000000]},
                      expect="capped"))
    cases.append(dict(kind="filter", label="a decode of 2^28 samples aborted", abort=True,
                      set={"FinestResolution": [2 ** 20], "OutputResolution": [2 ** 20, 2 ** 8, 1]}, expect="aborted"))
    return cases


def representation_cases():
    cases = []
    path = os.path.join(ROOT, "Representations", "NeuralVolumeRepresentation.xml.in")
    for name, tag, elements in xml_properties(path, "RepresentationProxy"):
        for values in value_cases(name, tag, elements):
            cases.append(dict(kind="render", set={name: values}))
    cases.append(dict(kind="render", label="DecodeResolution 4096^3", set={"DecodeResolution": [4096] * 3},
                      expect="decoded at"))
    for shading in (3, 4):
        cases.append(dict(kind="render", set={"ShadingMode": [shading], "TargetSamples": [INT_MAX]}))
        cases.append(dict(kind="render", set={"ShadingMode": [shading], "SamplesPerPixel": [INT_MAX],
                                             "MaxBounces": [INT_MAX]}))
    return cases


def label(case):
    if "label" in case:
        return case["label"]
    if case["kind"] == "command":
        return "%s (%s)" % (case["command"], case["when"])
    return ", ".join("%s=%s" % (k, v if len(str(v)) < 40 else str(v)[:37] + "...") for k, v in case["set"].items())


# --- the worker: runs cases [first, last) and records each in the progress file --------------------------------------

def worker(kind, first, last, progress_path):
    from paraview.simple import Wavelet, Show, Render, ColorBy, Delete, GetColorTransferFunction
    from paraview import servermanager
    nvtest.load_plugin(globals(), scripted=False)
    cases = filter_cases() if kind == "filter" else representation_cases()
    progress = open(progress_path, "a")
    inputs = {}

    def wavelet(n):
        if n not in inputs:
            inputs[n] = Wavelet(WholeExtent=[0, n - 1] * 3)
        return inputs[n]

    def set_raw(proxy, name, values):
        prop = proxy.SMProxy.GetProperty(name)
        if prop is None:
            raise KeyError("no property " + name)
        if prop.IsA("vtkSMStringVectorProperty") or prop.IsA("vtkSMVectorProperty"):
            for i, v in enumerate(values):
                prop.SetElement(i, v)
        proxy.SMProxy.UpdateVTKObjects()

    def new_filter(case):
        nc = globals()["NeuralCompress"](Input=wavelet(case.get("input", 16)))
        set_raw(nc, "SelectInputScalars", ["0", "0", "0", "0", "RTData"])
        for k, v in FILTER_BASE.items():
            set_raw(nc, k, [v])
        return nc

    def outcome(data):
        """'network' when output 0 carries a network, else 'empty'."""
        return "network" if data is not None and data.GetFieldData().GetArray("NeuralNetwork") else "empty"

    def drawn(view):
        """True when the view shows more than its background (the Neural Volume drew the network)."""
        import numpy as np
        path = os.path.join(nvtest.output_dir(), "extremes-render.png")
        nvtest.shot(view, path, [48, 48])
        pixels = nvtest.read_png(path)
        return bool((np.abs(pixels - np.array(BACKGROUND) * 255.0).max(axis=2) > 12.0).sum() > 20)

    def stop_long_decodes(caller, event):
        if caller.GetProgress() > 0.9505:  # training reports up to 0.95, the decode beyond: stop after 1% of it
            caller.SetAbortExecute(1)

    view = display = network = None
    if kind == "render":
        network = new_filter({})
        set_raw(network, "OutputMode", [0])
        network.UpdatePipeline()
        view = nvtest.render_view([48, 48], BACKGROUND)
        nvtest.set_camera(view, [40.0, -30.0, 55.0], focal=(7.5, 7.5, 7.5))

    for index in range(first, last):
        case = cases[index]
        progress.write(json.dumps(dict(begin=index)) + "\n")
        progress.flush()
        os.fsync(progress.fileno())
        result = dict(end=index)
        start = time.time()
        try:
            with nvtest.captured_messages() as messages:
                if case["kind"] == "filter":
                    nc = new_filter(case)
                    for k, v in case["set"].items():
                        set_raw(nc, k, v)
                    # A long decode (2^20 x 2^8 samples of a FinestResolution 2^20 network) reports progress and is
                    # aborted.
                    nc.GetClientSideObject().AddObserver("ProgressEvent", stop_long_decodes)
                    nc.UpdatePipeline()
                    data = servermanager.Fetch(nc)
                    result["outcome"] = outcome(data)
                    result["seconds_trained"] = nvtest.field_value(data, "NeuralTrainingSeconds")
                    result["arrays"] = data.GetPointData().GetNumberOfArrays() if data else 0
                    Delete(nc)
                elif case["kind"] == "command":
                    nc = new_filter(case)
                    if case["when"] == "background":
                        set_raw(nc, "TrainInBackground", [1])
                        set_raw(nc, "TimeBudget", [1.0])
                        set_raw(nc, "TrainingSteps", [INT_MAX])
                    if case["when"] != "before":
                        nc.UpdatePipeline()
                    set_raw(nc, "ContinueSteps", [50])
                    nc.SMProxy.InvokeCommand(case["command"])
                    if case["when"] == "background":
                        nc.SMProxy.InvokeCommand("StopTraining")
                        nc.SMProxy.InvokeCommand("WaitForTraining")
                    nc.UpdatePipeline()
                    result["outcome"] = outcome(servermanager.Fetch(nc))
                    Delete(nc)
                else:
                    if display is None:
                        display = Show(network, view)
                        ColorBy(display, ("POINTS", "RTData"))
                        display.SetRepresentationType("Neural Volume")
                        GetColorTransferFunction("RTData").RescaleTransferFunction(0.0, 300.0)
                        set_raw(display, "ProgressiveRefinement", [1])  # the GUI's mode: one refinement per render
                        Render(view)
                    renders = nvtest.info(display, "EngineRenderCount")
                    saved = {}
                    for k, v in case["set"].items():
                        prop = display.SMProxy.GetProperty(k)
                        saved[k] = [prop.GetElement(i) for i in range(prop.GetNumberOfElements())]
                        set_raw(display, k, v)
                    Render(view)
                    Render(view)
                    result["outcome"] = "image" if nvtest.info(display, "EngineRenderCount") > renders else "same"
                    # Back to the base before the next case (a huge grid's background decode is cancelled): the
                    # network is drawn again.
                    for k, v in saved.items():
                        set_raw(display, k, v)
                    Render(view)
                    result["recovered"] = drawn(view)
        except Exception as e:  # a Python-level failure of the case itself (not a crash)
            result["exception"] = repr(e)
        text = messages[0] if messages else ""
        result["error"] = "ERROR" in text or "Error" in text
        result["message"] = text[:2000]
        result["seconds"] = round(time.time() - start, 2)
        progress.write(json.dumps(result) + "\n")
        progress.flush()
        os.fsync(progress.fileno())
    progress.close()
    nvtest._exit(0)


# --- the parent: runs the workers, judges each case -------------------------------------------------------------------

def run_all(kind, cases, flags):
    out = nvtest.output_dir()
    progress_path = os.path.join(out, "extremes-%s.jsonl" % kind)
    open(progress_path, "w").close()
    done = {}
    first = 0
    while first < len(cases):
        env = dict(os.environ, NV_EXTREMES_WORKER="%s:%d:%d:%s" % (kind, first, len(cases), progress_path))
        command = [os.environ.get("NV_PVBATCH", "pvbatch")] + flags + [os.path.abspath(__file__)]
        with open(os.path.join(out, "extremes-%s-%d.log" % (kind, first)), "w") as log_file:
            try:
                rc = subprocess.run(command, env=env, stdout=log_file, stderr=subprocess.STDOUT,
                                    timeout=WORKER_SECONDS).returncode
            except subprocess.TimeoutExpired:
                rc = "timeout"
        begun = None
        with open(progress_path) as f:
            for line in f:
                record = json.loads(line)
                if "begin" in record:
                    begun = record["begin"]
                else:
                    done[record["end"]] = record
                    begun = None
        if begun is not None:
            nvtest.check(False, "%s case '%s': the worker %s" % (
                kind, label(cases[begun]), "hung" if rc == "timeout" else "died (exit status %s)" % rc))
            first = begun + 1
        elif len(done) and max(done) + 1 > first:
            first = max(done) + 1
            if rc != 0 and first < len(cases):
                nvtest.check(False, "%s worker ended with status %s between cases" % (kind, rc))
        else:
            nvtest.check(False, "%s worker did not start (status %s)" % (kind, rc))
            break
    return done


def judge(kind, cases, done):
    for index, case in enumerate(cases):
        record = done.get(index)
        if record is None:
            continue  # reported by run_all
        name = "%s case '%s'" % (kind, label(case))
        nvtest.check("exception" not in record, "%s: %s" % (name, record.get("exception")))
        if kind == "render":
            # A render returns (an image, an unchanged one, or an error message); the base settings draw again.
            nvtest.check(record.get("recovered"), "%s: the network is not drawn after the base settings are back"
                         % name)
        else:
            # An error message, or a result: a network.
            nvtest.check(record["error"] or record.get("outcome") == "network",
                         "%s: neither an error message nor a network (%s)" % (name, record.get("outcome")))
        if "expect" in case:
            nvtest.check(case["expect"] in record["message"],
                         "%s: the messages do not say '%s': %r" % (name, case["expect"], record["message"][:600]))
        if "budget" in case:
            seconds = record.get("seconds_trained") or 0.0
            nvtest.log("%s: %.3f s of training for a %.1f s budget" % (name, seconds, case["budget"]))
            nvtest.check(0.0 < seconds <= 1.1 * case["budget"],
                         "%s: trained %.3f s, more than the budget + 10%%" % (name, seconds))
        if case.get("abort"):
            nvtest.check(record.get("outcome") == "network" and record.get("arrays") == 0,
                         "%s: the aborted decode should leave the network only (%s, %s arrays)"
                         % (name, record.get("outcome"), record.get("arrays")))


if os.environ.get("NV_EXTREMES_WORKER"):
    kind, first, last, path = os.environ["NV_EXTREMES_WORKER"].split(":", 3)
    worker(kind, int(first), int(last), path)
else:
    nvtest.require_display()
    flags = ["--force-offscreen-rendering"]
    started = time.time()
    for kind, cases in (("filter", filter_cases()), ("render", representation_cases())):
        done = run_all(kind, cases, flags)
        judge(kind, cases, done)
        errors = sum(1 for r in done.values() if r["error"])
        nvtest.log("%s: %d cases, %d with an error message, %d crashed or hung, %.0f s so far" % (
            kind, len(cases), errors, len(cases) - len(done), time.time() - started))
    nvtest.finish()
