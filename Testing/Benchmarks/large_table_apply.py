"""What the GUI thread spends on Neural Compress with a large table (issue 28): pvbatch, a 128^3 Wavelet, background
training on the CPU engine, Log2TableSize from the command line. Times the Apply (the first UpdatePipeline of the
filter, its input already up to date) and then forced re-executions every 50 ms for a while (what each live refresh
costs the thread that runs the pipeline: the GUI thread in the GUI), and when the output first carries a network.

    pvbatch Testing/Benchmarks/large_table_apply.py PLUGIN LOG2 SECONDS [more LOG2 ...]
"""
import json
import sys
import time

from paraview.simple import *  # noqa: F401,F403

LoadPlugin(sys.argv[1], ns=globals())
seconds = float(sys.argv[3])
results = {}
for log2 in [int(sys.argv[2])] + [int(a) for a in sys.argv[4:]]:
    wavelet = Wavelet(WholeExtent=[-63, 64] * 3)
    wavelet.UpdatePipeline()
    nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], Log2TableSize=log2,
                        TrainInBackground=1, TrainingSteps=1000000, TimeBudget=0)
    started = time.perf_counter()
    nc.UpdatePipeline()
    apply_s = time.perf_counter() - started
    algo = nc.SMProxy.GetClientSideObject()
    refresh, first_network = [], None
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        time.sleep(0.05)
        t = time.perf_counter()
        algo.Modified()
        nc.SMProxy.MarkModified(nc.SMProxy)
        nc.UpdatePipeline()
        refresh.append(time.perf_counter() - t)
        net = algo.GetOutputDataObject(0).GetFieldData().GetAbstractArray("NeuralNetwork")
        if net is not None and first_network is None:
            first_network = time.perf_counter() - started
    nc.StopTraining()
    refresh.sort()
    results[log2] = {"apply_s": apply_s, "refreshes": len(refresh), "refresh_median_s": refresh[len(refresh) // 2],
                     "refresh_max_s": refresh[-1], "first_network_after_s": first_network,
                     "network_bytes": net.GetNumberOfTuples() if net is not None else 0}
    print("2^%d: Apply %.3f s; %d refreshes, median %.4f s, max %.4f s; network in the output after %s s (%d bytes)"
          % (log2, apply_s, len(refresh), results[log2]["refresh_median_s"], results[log2]["refresh_max_s"],
             "%.2f" % first_network if first_network else "-", results[log2]["network_bytes"]), flush=True)
    Delete(nc)
    Delete(wavelet)
print(json.dumps(results))
