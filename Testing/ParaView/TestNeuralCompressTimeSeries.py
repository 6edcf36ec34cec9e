"""Time-varying input: time step t warm-starts the training of t+1 and needs fewer steps to the same PSNR than a
cold start; networks are cached per time step (stepping back trains nothing); the metrics table has a row per time
step; the voreen OpenLB flow series (when NV_DATA_DIR has it) too."""
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

import numpy as np  # noqa: E402
from paraview.simple import *  # noqa: E402,F401,F403

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log

# A field that moves a little from one time step to the next (a vortex drifting), written as a .pvd series.
N, STEPS = 40, 5
folder = os.path.join(nvtest.output_dir(), "timeseries")
os.makedirs(folder, exist_ok=True)
pvd, _ = nvtest.drifting_series(folder, N, STEPS)

NET = dict(BatchSize=8192, Levels=10, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2, Loss="L2", Threads=2,
           TargetCompressionRatio=1.5, Deterministic=0, TimeBudget=0)
TARGET = 40.0  # dB; a cold start needs a few hundred steps (measured in the log below)


def run_series(reader, array, warm, target, times, max_steps):
    nc = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", array], TrainingSteps=max_steps,
                        TargetPSNR=target, PSNRInterval=10, WarmStart=warm, **NET)
    steps, seconds = [], []
    for t in times:
        nc.UpdatePipeline(t)
        out = nc.GetClientSideObject().GetOutputDataObject(0)
        steps.append(int(nvtest.field_value(out, "NeuralSteps")))
        seconds.append(nvtest.field_value(out, "NeuralTrainingSeconds"))
        check(nvtest.field_value(out, "NeuralWarmStart") == (1 if warm and t != times[0] else 0),
              "t=%g: NeuralWarmStart says %s" % (t, warm and t != times[0]))
        check(nvtest.field_value(out, "NeuralPSNR") >= target - 1.0,
              "t=%g: PSNR %.2f near the target %.1f" % (t, nvtest.field_value(out, "NeuralPSNR"), target))
    return nc, steps, seconds


reader = PVDReader(FileName=pvd)
times = list(reader.TimestepValues)
check(len(times) == STEPS, "the series has %d time steps" % STEPS)
cold, cold_steps, cold_s = run_series(reader, "f", 0, TARGET, times, 1500)
warm, warm_steps, warm_s = run_series(reader, "f", 1, TARGET, times, 1500)
log("steps to %.0f dB per time step: cold %r, warm %r" % (TARGET, cold_steps, warm_steps))
log("seconds: cold %.2f, warm %.2f (time steps 1..%d)" % (sum(cold_s[1:]), sum(warm_s[1:]), STEPS - 1))
check(warm_steps[0] == cold_steps[0], "the first time step trains cold either way")
check(sum(warm_steps[1:]) < 0.6 * sum(cold_steps[1:]), "warm start needs under 60% of the cold steps")

# Cache: stepping back shows the cached network without a training step; one metrics row per time step.
warm.SMProxy.UpdatePropertyInformation()
before = warm.GetPropertyValue("TotalStepsTrained")
for t in (times[1], times[0], times[3]):
    warm.UpdatePipeline(t)
    out = warm.GetClientSideObject().GetOutputDataObject(0)
    check(abs(nvtest.field_value(out, "NeuralTime") - t) < 1e-12, "t=%g: the network of that time step" % t)
warm.SMProxy.UpdatePropertyInformation()
check(warm.GetPropertyValue("TotalStepsTrained") == before, "stepping back and forth trains nothing")
metrics = warm.GetClientSideObject().GetOutputDataObject(2)
check(metrics.GetNumberOfRows() == STEPS, "metrics: a row per time step (%d)" % metrics.GetNumberOfRows())
check(list(metrics.GetColumnByName("Time").GetValue(i) for i in range(metrics.GetNumberOfRows())) == times,
      "metrics rows ordered by time")
check(all(metrics.GetColumnByName("WarmStart").GetValue(i) == (0 if i == 0 else 1) for i in range(STEPS)),
      "metrics: WarmStart per time step")

# Continue on a cached network: the step count goes on from it, exactly ContinueSteps more.
warm.UpdatePipeline(times[1])
cached_steps = int(nvtest.field_value(warm.GetClientSideObject().GetOutputDataObject(0), "NeuralSteps"))
warm.ContinueSteps = 30
warm.ContinueTraining()
warm.UpdatePipeline(times[1])
out = warm.GetClientSideObject().GetOutputDataObject(0)
check(int(nvtest.field_value(out, "NeuralSteps")) == cached_steps + 30,
      "ContinueTraining on a cached network: %d + 30 steps (%d)" % (cached_steps, nvtest.field_value(out, "NeuralSteps")))
check(out.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0) == "Finished", "continued and finished")

# A tiny cache keeps only the current time step: going back trains again.
warm.NetworkCacheMiB = 0
warm.UpdatePipeline(times[4])
warm.SMProxy.UpdatePropertyInformation()
before = warm.GetPropertyValue("TotalStepsTrained")
warm.UpdatePipeline(times[2])
warm.SMProxy.UpdatePropertyInformation()
check(warm.GetPropertyValue("TotalStepsTrained") > before, "a network evicted from the cache is trained again")


def update_until_training(proxy, t, seconds=60.0):
    """UpdatePipeline(t) until the output is the network of time step t (on a loaded machine a background
    execution may return while the field is still prepared: the output then says Preparing, or shows the previous
    time step's network). Returns the output."""
    start = time.time()
    while True:
        proxy.UpdatePipeline(t)
        out = proxy.GetClientSideObject().GetOutputDataObject(0)
        state = nvtest.field_value(out, "NeuralTrainingState")
        shown = nvtest.field_value(out, "NeuralTime")
        if (state in ("Starting", "Training") and shown is not None and abs(shown - t) < 1e-12) \
                or time.time() - start > seconds:
            return out
        time.sleep(0.05)
        proxy.SMProxy.GetClientSideObject().Modified()
        proxy.SMProxy.MarkModified(proxy.SMProxy)


# Background training through an animation: moving on cuts the running time step short; its network is kept
# ("Interrupted", in the metrics) and coming back continues it (warm) instead of showing it as final.
live = NeuralCompress(Input=reader, SelectInputScalars=["POINTS", "f"], TrainingSteps=100000, PSNRInterval=0,
                      TrainInBackground=1, **NET)
update_until_training(live, times[0])
update_until_training(live, times[1])
metrics = live.GetClientSideObject().GetOutputDataObject(2)
states = {metrics.GetColumnByName("Time").GetValue(i): metrics.GetColumnByName("State").GetValue(i)
          for i in range(metrics.GetNumberOfRows())}
log("background run, after moving to t=%g: %r" % (times[1], states))
check(states.get(times[0]) == "Interrupted", "the time step left while training is kept as Interrupted")
out = update_until_training(live, times[0])
check(out.GetFieldData().GetAbstractArray("NeuralTrainingState").GetValue(0) in ("Starting", "Training"),
      "coming back to an interrupted time step trains it again")
check(nvtest.field_value(out, "NeuralWarmStart") == 1, "... from its own interrupted network")
live.StopTraining()
live.WaitForTraining()

# Real data: the OpenLB flow (velocity magnitude), 6 time steps, when present.
data_dir = os.environ.get("NV_DATA_DIR", "")
flow = os.path.join(data_dir, "voreen_openlb_flow_timeseries", "flow_demo_A.pvd")
if data_dir and os.path.exists(flow):
    flow_reader = PVDReader(FileName=flow)
    flow_times = list(flow_reader.TimestepValues)[10:16]
    _, c_steps, c_s = run_series(flow_reader, "physVelocity", 0, 46.0, flow_times, 2000)
    _, w_steps, w_s = run_series(flow_reader, "physVelocity", 1, 46.0, flow_times, 2000)
    log("OpenLB flow, steps to 46 dB: cold %r, warm %r; seconds cold %.2f, warm %.2f"
        % (c_steps, w_steps, sum(c_s[1:]), sum(w_s[1:])))
    check(sum(w_steps[1:]) < sum(c_steps[1:]), "OpenLB flow: warm start needs fewer steps than cold")
else:
    log("OpenLB flow series not found under NV_DATA_DIR: that part is skipped")

nvtest.finish()
