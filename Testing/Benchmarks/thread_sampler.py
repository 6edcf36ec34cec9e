"""Where a thread spends its time, without a profiler: samples /proc/PID/task/TID/stat (state) and .../syscall (the
system call it waits in) every 0.5 ms until SIGTERM, then writes a JSON summary: the share of samples running
(state R) and, for the others, the share per system call (poll, futex, ioctl, ...). Used by gui_frames_script.py
(NV_GUI_SAMPLE=1) on the GUI's main thread during each drag.   usage: thread_sampler.py PID TID OUT.json"""
import json
import signal
import sys
import time

NAMES = {0: "read", 1: "write", 7: "poll", 16: "ioctl", 23: "select", 35: "nanosleep", 202: "futex", 232: "epoll_wait",
         270: "pselect6", 271: "ppoll", 230: "clock_nanosleep", 281: "epoll_pwait", 20: "writev", 47: "recvmsg"}
pid, tid, out = sys.argv[1], sys.argv[2], sys.argv[3]
counts, running, total = {}, 0, 0
stop = []
signal.signal(signal.SIGTERM, lambda *a: stop.append(1))
base = "/proc/%s/task/%s/" % (pid, tid)
while not stop:
    try:
        with open(base + "stat") as f:
            state = f.read().rsplit(")", 1)[1].split()[0]
        total += 1
        if state == "R":
            running += 1
        else:
            with open(base + "syscall") as f:
                first = f.read().split()[0]
            name = "running" if first == "running" else NAMES.get(int(first), first) if first.lstrip("-").isdigit() \
                else first
            counts[name] = counts.get(name, 0) + 1
    except (OSError, IndexError, ValueError):
        break
    time.sleep(0.0005)
summary = {"samples": total, "running": round(running / total, 3) if total else None,
           "waiting": {k: round(v / total, 3) for k, v in sorted(counts.items(), key=lambda kv: -kv[1])[:8]}}
with open(out, "w") as f:
    json.dump(summary, f)
