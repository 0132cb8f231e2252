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
# # Middle-ear chain: modes and the stapes transfer function
#
# `examples/middle_ear_chain.yaml` is the lumped four-mass middle-ear chain with the LVATB1
# values (tympanic membrane, malleus, incus, stapes on springs; `docs/middle-ear-data.md`),
# driven by the ear-canal pressure `p_ec`. Linearized at rest it gives its modes and the
# frequency response of the stapes velocity per ear-canal pressure. Normal ears peak at
# 0.6–1.5 kHz with 0.03–0.3 mm/s/Pa (`docs/middle-ear-measurements.md` §1).

# %%
from pathlib import Path

import numpy as np

from neweul_py.analysis import frequency_response, linearize, modes
from neweul_py.api import load_description_module

try:
    HERE = Path(__file__).resolve().parent
except NameError:
    HERE = Path.cwd()
module = load_description_module(HERE.parent / "middle_ear_chain.yaml")
lin = linearize(module)

# %% [markdown]
# ## Modes
# Damped natural frequencies and damping ratios of `M0 ÿ + P ẏ + Q y = 0`.

# %%
shapes = modes(lin)
print(shapes.table())

# %% [markdown]
# ## Frequency response
# `frequency_response` solves `(−ω²M0 + jωP + Q) y = B u` at every frequency and returns
# `H` of shape (frequencies, outputs, inputs); `plot` draws magnitude and phase.

# %%
f = np.geomspace(100.0, 10_000.0, 400)
response = frequency_response(lin, f, "p_ec", ["stapes_velocity", "umbo_velocity"])
h = np.abs(response.H[:, 0, 0])
k = int(np.argmax(h))
print(f"stapes peak {h[k] * 1e3:.3f} mm/s/Pa at {f[k]:.0f} Hz")
assert 0.6e3 < f[k] < 1.5e3 and 0.03e-3 < h[k] < 0.3e-3
figure = response.plot()
