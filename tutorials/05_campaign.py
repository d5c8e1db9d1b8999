# %% [markdown]
# # 5. A campaign with `mitsar sweep`
#
# A design question ("how does the image quality change with the look angle and the speed?")
# is a sweep: every point of a grid of experiment keys is simulated, focused and measured, and
# the results form one table. `mitsar sweep` runs it on a Dask cluster (or inline), resumably,
# with the same numbers on 1 or N workers ([Experiments](../experiments.md#campaigns),
# [Command line](../cli.md)).

# %%
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import xarray as xr

from mitsar.experiment.examples import example_path

QUICK = os.environ.get("MITSAR_TUTORIAL_QUICK") == "1"
experiment = example_path("campaign_tiny")
out = Path(tempfile.mkdtemp(prefix="mitsar-sweep-"))
print(experiment.read_text())

# %% [markdown]
# ## Run it
#
# `--vary KEY=START:STOP:STEP` (inclusive) or `KEY=V1,V2,...`, any dotted experiment key.
# `--scheduler inline` runs in this process; leave it out for a local cluster with one worker
# per core, or give `tcp://host:8786` for a cluster.

# %%
angles = "54:57:3" if QUICK else "54:57:1.5"
command = [sys.executable, "-m", "mitsar.cli", "sweep", str(experiment),
           "--vary", f"look.off_nadir_deg={angles}", "--vary", "trajectory.speed=0.5,1.0",
           "--scheduler", "inline", "-q", "-o", str(out)]
print(" ".join(command[2:]))
subprocess.run(command, check=True)
print(sorted(p.name for p in out.iterdir()))

# %% [markdown]
# ## The table
#
# `sweep.nc` has one dimension per varied key, then `realisation` and `algorithm`;
# `sweep.csv` is the same as one row per run.

# %%
table = xr.open_dataset(out / "sweep.nc")
print(table["azimuth_irw_cells"].squeeze().to_pandas() if "azimuth_irw_cells" in table
      else table)

# %% [markdown]
# A figure per metric is in `figures/`; the Monte Carlo form (`mitsar montecarlo`) repeats one
# point with new seeds for the paper's Tables 4–5. Next: [interferometry](06_interferometry.md).
