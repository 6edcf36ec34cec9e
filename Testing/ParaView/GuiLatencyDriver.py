"""Real input for GuiLatencyScript.py: moves and drags the X pointer with xdotool, logging when each event was sent
("time x y" per line; the event is in the X server's queue when xdotool returns).
  find                       one move to the middle of the largest window
  drag X Y STEPS DX PAUSE    press at (X, Y), STEPS moves of DX pixels PAUSE seconds apart, release"""
import argparse
import subprocess
import time


def xdotool(*args):
    return subprocess.run(["xdotool"] + [str(a) for a in args], check=True, stdout=subprocess.PIPE,
                          text=True).stdout


parser = argparse.ArgumentParser()
parser.add_argument("--log", required=True)
parser.add_argument("mode", choices=["find", "drag"])
parser.add_argument("args", nargs="*", type=float)
a = parser.parse_args()
with open(a.log, "w") as log:
    if a.mode == "find":
        # The ParaView main window: the largest visible one.
        best = None
        for wid in xdotool("search", "--onlyvisible", "--name", "ParaView").split():
            geometry = xdotool("getwindowgeometry", "--shell", wid)
            g = dict(line.split("=") for line in geometry.split())
            area = int(g["WIDTH"]) * int(g["HEIGHT"])
            if best is None or area > best[0]:
                best = (area, int(g["X"]), int(g["Y"]), int(g["WIDTH"]), int(g["HEIGHT"]))
        _, x, y, w, h = best
        sx, sy = x + w // 2, y + h // 2
        xdotool("mousemove", sx, sy)
        time.sleep(0.2)
        xdotool("mousemove", sx + 1, sy)
        log.write("%.6f %d %d\n" % (time.time(), sx + 1, sy))
    else:
        x, y, steps, dx, pause = a.args
        x, y = int(x), int(y)
        xdotool("mousemove", x, y)
        time.sleep(0.3)
        xdotool("mousedown", 1)
        for k in range(1, int(steps) + 1):
            time.sleep(pause)
            xdotool("mousemove", x + int(dx) * k, y)
            log.write("%.6f %d %d\n" % (time.time(), x + int(dx) * k, y))
            log.flush()
        xdotool("mouseup", 1)
