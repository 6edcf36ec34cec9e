"""Markdown table from gui_frames_script.py JSON files: usage summarize_gui_frames.py LABEL=gui_frames.json ..."""
import json, sys
print("| run (window) | view | what | FPS during the drag | median gap ms | p90 gap ms | inside Render() ms | outside ms | GUI thread running | training share |")
print("|---|---|---|---|---|---|---|---|---|---|")
for label, path in [a.rsplit("=", 1) for a in sys.argv[1:]]:
    d = json.load(open(path))
    for s, v in d["sizes"].items():
        for k, e in v.items():
            if k in ("view", "still"):
                continue
            if "error" in e:
                print("| %s | %s | %s | (%s) | | | | | | |" % (label, "x".join(map(str, v["view"])), k, e["error"]))
                continue
            mt = e.get("main_thread", {})
            print("| %s | %s | %s | %.1f | %.1f | %.1f | %.2f | %.2f | %s | %s |" % (
                label, "x".join(map(str, v["view"])), k, e["fps"], e["frame_gap_median_ms"], e["frame_gap_p90_ms"],
                e["inside_render_median_ms"], e["outside_render_median_ms"],
                "%.0f%%" % (100 * mt["running"]) if mt.get("running") is not None else "--",
                e.get("training_share", "--")))
