"""Real input for GuiLatencyScript.py: moves and drags the X pointer with xdotool, logging when each event was sent
("time x y" per line; the event is in the X server's queue when xdotool returns).
  find                       one move to the middle of the largest window
  scan                       moves over a grid of points of the largest window, 0.3 s apart, each logged before
                             it is sent (the GUI's first handled move then says where its view lies)
  drag X Y STEPS DX PAUSE    press at (X, Y), STEPS moves of DX pixels PAUSE seconds apart, release
  stream X Y STEPS DX PERIOD press at (X, Y), then STEPS moves of DX pixels every PERIOD seconds from one xdotool
                             process (a steady input faster than the GUI draws: no process start per move), release"""
import argparse
import subprocess
import time


def xdotool(*args):
    return subprocess.run(["xdotool"] + [str(a) for a in args], check=True, stdout=subprocess.PIPE,
                          text=True).stdout


parser = argparse.ArgumentParser()
parser.add_argument("--log", required=True)
parser.add_argument("mode", choices=["find", "scan", "drag", "stream"])
parser.add_argument("args", nargs="*", type=float)
a = parser.parse_args()


def main_window():
    """The window holding the render view: the full-screen layout's (a window named just "ParaView") when it is
    shown, else the largest visible ParaView window (the main one): (x, y, width, height, id)."""
    best = None
    for wid in xdotool("search", "--onlyvisible", "--class", "ParaView").split():
        geometry = xdotool("getwindowgeometry", "--shell", wid)
        g = dict(line.split("=") for line in geometry.split())
        area = int(g["WIDTH"]) * int(g["HEIGHT"])
        full_screen = xdotool("getwindowname", wid).strip() == "ParaView" and area > 1
        rank = (full_screen, area)
        if best is None or rank > best[0]:
            best = (rank, int(g["X"]), int(g["Y"]), int(g["WIDTH"]), int(g["HEIGHT"]), wid)
    return best[1:]


with open(a.log, "w") as log:
    if a.mode in ("find", "scan"):
        x, y, w, h, wid = main_window()
        if a.mode != "find":
            xdotool("windowraise", wid)  # above ParaView's Output Messages dialog, which pops up over it
        if a.mode == "scan":
            for fy in (0.5, 0.4, 0.6, 0.3, 0.7):
                for fx in (0.5, 0.4, 0.6, 0.3, 0.7, 0.2, 0.15, 0.8):
                    sx, sy = x + int(w * fx), y + int(h * fy)
                    log.write("%.6f %d %d\n" % (time.time(), sx, sy))
                    log.flush()
                    xdotool("mousemove", sx, sy)
                    time.sleep(0.3)
            raise SystemExit(0)
        sx, sy = x + w // 2, y + h // 2
        xdotool("mousemove", sx, sy)
        time.sleep(0.2)
        xdotool("mousemove", sx + 1, sy)
        log.write("%.6f %d %d\n" % (time.time(), sx + 1, sy))
    elif a.mode == "stream":
        x, y, steps, dx, period = a.args
        x, y = int(x), int(y)
        xdotool("windowraise", main_window()[4])
        xdotool("mousemove", x, y)
        time.sleep(0.3)
        chain = ["mousedown", 1]
        for k in range(1, int(steps) + 1):
            chain += ["mousemove", x + int(dx) * k, y, "sleep", period]
        log.write("%.6f %d %d\n" % (time.time(), x, y))
        xdotool(*(chain + ["mouseup", 1]))
        log.write("%.6f %d %d\n" % (time.time(), x + int(dx) * int(steps), y))
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
