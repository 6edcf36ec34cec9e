"""Markdown tables from gpu_paraview_frames.py's JSON files (issue 24): per view size, Render() of an empty view, of
stock Volume and of each Neural Volume path (CUDA-OpenGL interop, still and interactive; the host path), the engine's
GPU time, and the frame's overhead beyond the empty view and the engine's GPU time, split into the engine call's own
(launch, synchronisation) and ParaView's outside the Neural Volume mapper; the path-tracing still (denoised and raw) in single passes' time and PSNR against 2048 paths and the converged picture;
training beside a turning view.   usage: summarize_gpu_frames.py FRAMES.json..."""
import json
import re
import sys

PATHS = ["Decode", "Sample Streaming", "In-Shader"]
PT_ROWS = []


def rows(data):
    for size in sorted((k for k in data if re.fullmatch(r"\d+x\d+", k)), key=lambda k: int(k.split("x")[0])):
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
        pt = r.get("path_tracing")
        if pt:
            PT_ROWS.append((data["data"], size, pt))


def pt_rows():
    """Path tracing + NEE still (Decode): time in single passes and PSNR against the raw 2048-path picture (and against
    the converged one: the reference's own noise, measured from its two halves, taken out)."""
    yield ("| data | view | paths | denoised: ms (passes of one) | PSNR vs 2048 | vs converged | raw: ms (passes of "
           "one) | PSNR vs 2048 | vs converged |")
    yield "|---|---|---|---|---|---|---|---|---|"
    fmt = lambda v: "%.1f" % v if v is not None else "--"  # noqa: E731
    for name, size, pt in PT_ROWS:
        yield "| %s | %s | 2048 (reference) | | %s vs converged | | | | |" % (
            name, size, fmt(pt.get("reference_psnr_vs_truth")))
        for target in (1, 4, 8, 16, 32, 64):
            d, w = pt["%d_denoised" % target], pt["%d_raw" % target]
            yield ("| %s | %s | %d | %.1f (%.1f) | %s | %s | %.1f (%.1f) | %s | %s |"
                   % (name, size, target, d["ms"], d["passes_of_one"], fmt(d["psnr_vs_reference"]),
                      fmt(d.get("psnr_vs_truth")), w["ms"], w["passes_of_one"], fmt(w["psnr_vs_reference"]),
                      fmt(w.get("psnr_vs_truth"))))

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
for line in pt_rows():
    print(line)
print()
print("| data | training alone (steps/s) | beside a turning 1920x1080 view | share | interactive renders/s |")
print("|---|---|---|---|---|")
for name, s in shares:
    print("| %s | %.0f | %.0f | %.2f | %.1f |" % (name, s["steps_per_s_alone"], s["steps_per_s_beside_view"],
                                                 s["share"] or 0.0, s["interactive_fps"]))
