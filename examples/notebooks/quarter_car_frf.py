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
# # Quarter car: linearization, modes and the frequency response to the road
#
# `examples/quarter_car.yaml` moves its road frame with the input `zr` (kinematic
# excitation). Linearized about the static equilibrium it has two modes — body bounce and
# wheel hop — and its frequency response from the road height to the tire force is the
# transfer function of the two-mass model (docs/analysis.md).

# %%
from pathlib import Path

import numpy as np

from neweul_py.analysis import equilibrium, frequency_response, linearize, modes
from neweul_py.analysis.plot import signal_units
from neweul_py.api import load_description_module

try:
    HERE = Path(__file__).resolve().parent
except NameError:
    HERE = Path.cwd()
module = load_description_module(HERE.parent / "quarter_car.yaml")

# %% [markdown]
# ## Static equilibrium and modes

# %%
rest = equilibrium(module, u={"zr": 0.0})
rest

# %%
lin = linearize(module, y0=rest.y, u0=np.zeros(len(module.INPUTS)))
shapes = modes(lin)
shapes

# %%
f = np.asarray(shapes.frequency_hz)
print("natural frequencies [Hz]:", ", ".join(f"{v:.2f}" for v in sorted(f[f > 0])))
assert 0.5 < min(f[f > 0]) < 2.0 and 8.0 < max(f) < 15.0   # body bounce, wheel hop

# %% [markdown]
# ## Frequency response from the road to the tire force
# The Bode magnitude is labelled with the output's unit per the input's (`N/m`).

# %%
response = frequency_response(lin, np.geomspace(0.3, 40.0, 200), "zr", "tire_force")
units = signal_units(module)
figure = response.plot(None, output_units=units, input_units=units)
assert figure.axes[0].get_ylabel() == "|tire_force/zr| [N/m]"
response
