"""Markdown tables from gpu_paraview_frames.py's JSON files (issue 24): per view size, Render() of an empty view, of
stock Volume and of each Neural Volume path (CUDA-OpenGL interop, still and interactive; the host path), the engine's
GPU time, and the frame's overhead beyond the empty view and the engine's GPU time, split into the engine call's own
(launch, synchronisation) and ParaView's outside the Neural Volume mapper; the path-tracing still against one pass;
training beside a turning view.   usage: summarize_gpu_frames.py FRAMES.json..."""
import json
import sys

PATHS = ["Decode", "Sample Streaming", "In-Shader"]


def rows(data):
    for size in ("1280x720", "1920x1080"):
        if size not in data:
            continue
        r = data[size]
        empty, stock = r["empty_ms"], r["stock_volume"]["render_ms"]
        for path in PATHS:
            for mode, label in (("_interop", "still"), ("_interop_interactive", "interactive"), ("_host", "still, host")):
                v = r[path + mode]
                gpu = v.get("engine_gpu_ms", v["engine_kernel_ms"])
                overhead = v["render_ms"] - empty - gpu
                call = v["engine_call_ms"] - gpu - v.get("engine_setup_ms", 0.0)
                outside = v["render_ms"] - v["mapper_ms"] - empty
                yield ("| %s | %s | %s | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |"
                       % (data["data"], size, "%s (%s)" % (path, label), empty, stock, v["render_ms"], gpu, overhead,
                          call, outside))
        yield ("| %s | %s | path tracing + NEE still, 64 paths/pixel vs one pass | | | %.0f vs %.1f (%.0fx) | | | | |"
               % (data["data"], size, r["pt_nee_still_64spp_ms"], r["pt_nee_one_pass_ms"],
                  r["pt_nee_still_64spp_ms"] / r["pt_nee_one_pass_ms"]))


print("| data | view | Neural Volume path | empty view | stock Volume | Neural Volume Render() | engine GPU | overhead "
      "beyond empty + engine GPU | of it: engine call | of it: outside the mapper |")
print("|---|---|---|---|---|---|---|---|---|---|")
shares = []
for path in sys.argv[1:]:
    with open(path) as f:
        data = json.load(f)
    for line in rows(data):
        print(line)
    for key in ("training_share", "training_share_unpaced"):
        if key in data:
            shares.append((data["data"] + ("" if key == "training_share" else " (renders not paced)"), data[key]))
print()
print("| data | training alone (steps/s) | beside a turning 1920x1080 view | share | interactive renders/s |")
print("|---|---|---|---|---|")
for name, s in shares:
    print("| %s | %.0f | %.0f | %.2f | %.1f |" % (name, s["steps_per_s_alone"], s["steps_per_s_beside_view"],
                                                 s["share"] or 0.0, s["interactive_fps"]))
