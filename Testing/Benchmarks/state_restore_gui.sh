#!/usr/bin/env bash
# The GUI side of a state restore: starts `paraview` under Xvfb with a script that loads the state, takes screenshots
# of the screen from the moment LoadState starts, and prints when the view first shows the Neural Volume and when
# LoadState returned. Usage: state_restore_gui.sh <plugin.so> <state.pvsm> [screenshots=60]
set -u
plugin=$1; state=$2; shots=${3:-60}
work=$(mktemp -d)
cat > "$work/load.py" <<PY
import time
from paraview.simple import *
LoadPlugin("$plugin", remote=False, ns=globals())
open("$work/t0.txt", "w").write("%.3f\n" % time.time())
LoadState("$state")
open("$work/t0.txt", "a").write("%.3f\n" % time.time())
PY
mkdir -p "$work/shots"
xvfb-run -a -s "-screen 0 1600x1000x24 -noreset" bash -c "
  paraview --dr --script=$work/load.py & P=\$!
  while [ ! -s $work/t0.txt ]; do sleep 0.05; done
  for i in \$(seq 1 $shots); do import -window root $work/shots/shot_\$(date +%s.%N).png; done
  kill \$P" > /dev/null 2>&1
/usr/bin/python3 - "$work" <<'PY'
import glob, os, sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(sys.argv[0] if sys.argv[0] != "-" else ".")), ""))
from vtkmodules.vtkIOImage import vtkPNGReader
from vtkmodules.util.numpy_support import vtk_to_numpy
work = sys.argv[1]
t = [float(x) for x in open(os.path.join(work, "t0.txt")).read().split()]
first = None
for f in sorted(glob.glob(os.path.join(work, "shots", "shot_*.png"))):
    r = vtkPNGReader(); r.SetFileName(f); r.Update()
    d = r.GetOutput().GetDimensions()
    p = vtk_to_numpy(r.GetOutput().GetPointData().GetScalars()).reshape(d[1], d[0], -1)[::-1, :, :3].astype(float)
    view = p[200:720, 300:1150]  # the render view of the 1600x1000 screen
    if first is None and ((view.max(axis=2) - view.min(axis=2)) > 40).mean() > 0.02:
        first = float(os.path.basename(f)[5:-4]) - t[0]
print("RESULT gui_state_restore first_picture_s %s loadstate_returned_s %s" % (
    "%.2f" % first if first is not None else "none", "%.2f" % (t[1] - t[0]) if len(t) > 1 else "not returned"))
PY
