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
# # Double pendulum: from a description to equations, motion and energy
#
# The planar double pendulum of `examples/double_pendulum.yaml` (two uniform rods, the second
# angle relative to the first) is loaded into a model, its equations of motion
# `M(y) ÿ = q − k` are derived and shown, and its motion is simulated; without friction the
# total energy stays constant, which checks the equations and the integrator at once.

# %%
from pathlib import Path

import numpy as np

import neweul_py
from neweul_py.analysis import simulate
from neweul_py.analysis.plot import result_figure
from neweul_py.api import derive, load_description_module

try:  # run as a script (the test suite, a docs build) or as a notebook next to its examples
    HERE = Path(__file__).resolve().parent
except NameError:
    HERE = Path.cwd()
DESCRIPTION = HERE.parent / "double_pendulum.yaml"

# %% [markdown]
# ## The model
# In a notebook a model shows as tables of its parameters, coordinates, bodies and outputs.

# %%
model = neweul_py.load_description(DESCRIPTION)
model

# %% [markdown]
# ## The equations of motion
# The mass matrix `M` and the force vector `q − k` in LaTeX; subexpressions that occur more
# than once are named `ξ₀, ξ₁ …` and defined first.

# %%
equations, _ = derive(DESCRIPTION)
equations

# %% [markdown]
# ## Simulation
# The generated module (from the content-hash cache after the first run) is integrated for
# 5 s at tight tolerances; the result shows as a table with units.

# %%
module = load_description_module(DESCRIPTION)
result = simulate(module, 5.0, method="DOP853", rtol=1e-10, atol=1e-10, n_out=501)
result

# %%
figure = result_figure(result)
figure

# %% [markdown]
# ## Energy
# Kinetic plus potential energy over the run: its largest change relative to the kinetic
# energy's range is the accuracy of the whole chain (a few 1e-9 at these tolerances).

# %%
p = module.default_parameters()
states = np.hstack([result.y, result.yd])
energy = np.array([module.energy(t, x, p) for t, x in zip(result.t, states, strict=True)])
total = energy.sum(axis=1)
drift = np.ptp(total) / np.ptp(energy[:, 0])
print(f"relative energy drift over {result.t[-1]:g} s: {drift:.2e}")
assert drift < 1e-6
