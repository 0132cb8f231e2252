# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Four-bar linkage: a closed loop, its constraint forces, and the same model as an FMU
#
# `examples/four_bar.yaml` closes a kinematic loop with a coincidence constraint. `simulate`
# integrates it as an index-1 DAE with projection; the constraint forces come with the
# result. The model is then exported as an FMI 2.0 FMU (docs/fmu-export.md) — an ODE in its
# independent coordinate — and simulated by FMPy, an independent FMI importer, for both
# model exchange and co-simulation. Needs a C compiler and FMPy (`pip install fmpy`).

# %%
from pathlib import Path

import numpy as np
from fmpy import simulate_fmu
from fmpy.validation import validate_fmu

from neweul_py.analysis import simulate
from neweul_py.api import derive, export_fmu, load_description_module

try:
    HERE = Path(__file__).resolve().parent
except NameError:
    HERE = Path.cwd()
DESCRIPTION = HERE.parent / "four_bar.yaml"

# %% [markdown]
# ## Equations with their constraint
# `M`, `q − k` and the loop-closure constraint `g(y) = 0`.

# %%
equations, _ = derive(DESCRIPTION)
equations

# %% [markdown]
# ## Simulation with constraint forces

# %%
module = load_description_module(DESCRIPTION)
T, TOL = 3.0, 1e-10
result = simulate(module, T, method="DOP853", rtol=TOL, atol=TOL, n_out=301)
result

# %% [markdown]
# ## The FMU
# One FMU with both interfaces; its states are the crank angle `phi1` and its rate (the
# coupler and rocker angles follow from the constraints at every evaluation).

# %%
fmu = export_fmu(DESCRIPTION, Path("out") / "four_bar.fmu", "both")   # out/: not committed
problems = validate_fmu(str(fmu))
print(f"{fmu.name}: {len(problems)} problems found by FMPy's validation")
assert problems == []

# %%
names = [*module.COORDINATES, *module.OUTPUTS]
reference = np.hstack([result.y, result.outputs[:, :len(module.OUTPUTS)]])
for kind in ("ModelExchange", "CoSimulation"):
    run = simulate_fmu(str(fmu), fmi_type=kind, stop_time=T, relative_tolerance=TOL,
                       output_interval=T / 300, output=names)
    worst = max(np.abs(run[n] - reference[:, k]).max() / np.abs(reference[:, k]).max()
                for k, n in enumerate(names))
    print(f"{kind}: largest relative difference to simulate {worst:.1e}")
    assert worst < 1e-6
