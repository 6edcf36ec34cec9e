"""Run the PyTorch reference (../shared/reference/quality_torch.py) unmodified with another seed.
The reference seeds itself with torch.manual_seed(0) before each volume; this wrapper makes that call use SEED
instead and runs the script as it is. Usage: torch_seeded.py SEED quality_torch.py bench_torch.py STEPS LOG2T FILES..."""
import runpy
import sys

import torch

seed = int(sys.argv[1])
_manual_seed = torch.manual_seed
torch.manual_seed = lambda _ignored: _manual_seed(seed)
script = sys.argv[2]
sys.argv = [script] + sys.argv[3:]
runpy.run_path(script, run_name="__main__")
