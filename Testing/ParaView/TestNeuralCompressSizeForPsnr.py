"""SizeForPSNR (issue 25: the best ratio at a target PSNR) on a 48^3 Wavelet, trained briefly on the CPU
(Deterministic): for two reachable targets the final network reaches its target, the summary says "reached" and lists
the sizes trained, and the higher target gets the larger table and the lower or equal ratio. The search is checked
against the filter itself: the chosen size's trial PSNR in the summary is the final network's (the same training), and
the table one size smaller, trained with Log2 Table Size set, misses the target. A target out of reach ends at the
better of the two largest tables that compress, with a "NOT reached" summary and a warning. Without SizeForPSNR the
automatic size is the ratio's, as before."""
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nvtest  # noqa: E402

from paraview.simple import *  # noqa: E402,F401,F403
from paraview import servermanager  # noqa: E402

nvtest.load_plugin(globals())
check, log = nvtest.check, nvtest.log

RUN = dict(TrainingSteps=300, BatchSize=8192, Levels=8, FeaturesPerLevel=2, NetworkWidth=32, HiddenLayers=2,
           Threads=2, Seed=1, Device="CPU", Deterministic=1, PSNRInterval=0, TimeBudget=0,
           TrainInBackground=0)

wavelet = Wavelet(WholeExtent=[-23, 24, -23, 24, -23, 24])


def run(**settings):
    with nvtest.captured_messages() as messages:
        nc = NeuralCompress(Input=wavelet, SelectInputScalars=["POINTS", "RTData"], **dict(RUN, **settings))
        nc.UpdatePipeline()
    out = servermanager.Fetch(nc)
    text = messages[0]
    table = re.search(r"\(2\^(\d+) table, (\w+)\)", text)
    r = dict(text=text, psnr=nvtest.field_value(out, "NeuralPSNR"),
             ratio=nvtest.field_value(out, "NeuralCompressionRatio"), log2=int(table.group(1)) if table else None,
             storage=table.group(2) if table else None)
    trained = re.search(r"trained in [\d.eE+-]+ s: ([^)]*)\)", text)
    r["trials"] = {int(m.group(1)): float(m.group(2)) for m in re.finditer(r"2\^(\d+) ([-\d.eE+naif]+) dB",
                                                                           trained.group(1))} if trained else {}
    log("%r: PSNR %.4f dB, ratio %.3f:1, 2^%s %s, trials %r" % (settings, r["psnr"], r["ratio"], r["log2"],
                                                             r["storage"], r["trials"]))
    Delete(nc)
    return r


sized = {}
for target in (30.0, 36.0):
    r = run(SizeForPSNR=target)
    check("ERROR" not in r["text"], "a clean run: %r" % r["text"])
    check(r["psnr"] is not None and not math.isnan(r["psnr"]), "a PSNR is reported")
    check(r["storage"] == "q8", "Automatic storage sizes 8-bit networks: %r" % r["storage"])
    check(r["psnr"] >= target, "target %g dB reached: %.4f dB" % (target, r["psnr"]))
    check("Size For PSNR %g dB reached" % target in r["text"], "the summary says it was reached: %r" % r["text"])
    check(r["log2"] in r["trials"], "the chosen 2^%s was among the sizes trained %r" % (r["log2"], r["trials"]))
    # The search's candidate and the job's network are the same training (Deterministic, same seed and steps).
    check(abs(r["trials"][r["log2"]] - r["psnr"]) < 0.01,
          "the final network has the PSNR the search measured for its size: %.4f vs %.4f"
          % (r["psnr"], r["trials"][r["log2"]]))
    smaller = r["log2"] - 1
    if smaller >= 10:
        below = run(Log2TableSize=smaller, StoragePrecision="8-bit (entropy coded)")
        check(below["psnr"] < target, "2^%d misses %g dB: %.4f (the chosen size is the smallest)"
              % (smaller, target, below["psnr"]))
        if smaller in r["trials"]:
            check(abs(r["trials"][smaller] - below["psnr"]) < 0.01, "the search measured 2^%d as the filter does: "
                  "%.4f vs %.4f" % (smaller, r["trials"][smaller], below["psnr"]))
    sized[target] = r
check(sized[36.0]["log2"] > sized[30.0]["log2"], "the higher target needs a larger table: 2^%d vs 2^%d"
      % (sized[36.0]["log2"], sized[30.0]["log2"]))
check(sized[36.0]["ratio"] <= sized[30.0]["ratio"], "the higher target gives the lower ratio: %.3f vs %.3f"
      % (sized[36.0]["ratio"], sized[30.0]["ratio"]))

# Out of reach: the better of the two largest tables that compress, said plainly.
far = run(SizeForPSNR=90.0)
check("Size For PSNR 90 dB NOT reached" in far["text"], "the summary says it was not reached: %r" % far["text"])
check("Warning" in far["text"] and "not reached" in far["text"], "a warning says so: %r" % far["text"])
largest = max(far["trials"])
check(sorted(far["trials"]) == [largest - 1, largest], "only the two largest were trained: %r" % far["trials"])
check(far["trials"][far["log2"]] == max(far["trials"].values()), "the better of the two is kept: 2^%d of %r"
      % (far["log2"], far["trials"]))
check(abs(far["trials"][far["log2"]] - far["psnr"]) < 0.01, "its final PSNR is the search's: %.4f" % far["psnr"])
check(largest >= sized[36.0]["log2"] and far["ratio"] >= 1.0,
      "the largest tables that compress: 2^%d at %.3f:1" % (far["log2"], far["ratio"]))
check(far["psnr"] < 90.0, "its PSNR %.4f is below the target" % far["psnr"])

# Off: the ratio's automatic size, no search.
plain = run()
check("sized for PSNR" not in plain["text"] and "Size For PSNR" not in plain["text"], "no search without it")

nvtest.finish()
