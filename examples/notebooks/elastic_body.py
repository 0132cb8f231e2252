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
# # An elastic body: FE model, two-sided reduction, multibody model
#
# The FE model of `examples/elastic_up_body/` is a spring–mass piston closing a 1-D air duct
# in the pressure-based u–p form (102 DOFs, unsymmetric mass and stiffness matrices,
# `docs/equations.md` §3). It is reduced to 12 modes by a two-sided (Petrov–Galerkin)
# projection with left and right eigenvectors, its floating-frame invariants are attached,
# and the body file enters the description `model.yaml`: fixed to the ground, a rigid mass on
# a spring–damper at the piston node. The frequency response of the mass to a force on it is
# compared with the unreduced FE model assembled directly with the same spring, damper and
# mass — and with a one-sided (Galerkin) reduction of the same order.

# %%
import importlib.util
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from neweul_py.analysis import frequency_response, linearize
from neweul_py.api import load_description_module
from neweul_py.elastic import reduce_modal, save_reduced_body
from neweul_py.elastic.reductors.invariants import attach_invariants

try:
    HERE = Path(__file__).resolve().parent
except NameError:
    HERE = Path.cwd()
EXAMPLE = HERE.parent / "elastic_up_body"
spec = importlib.util.spec_from_file_location("make_fe", EXAMPLE / "make_fe.py")
make_fe = importlib.util.module_from_spec(spec)
spec.loader.exec_module(make_fe)

fe = make_fe.piston_duct()
print(fe.name, fe.kind, fe.n_dofs, "DOFs")

# %% [markdown]
# ## Reduce, attach the invariants, write the body file
# The description reads `body.npz` next to it, so both go to a scratch directory.

# %%
work = Path(tempfile.mkdtemp())
shutil.copy(EXAMPLE / "model.yaml", work / "model.yaml")
f = np.linspace(20.0, 900.0, 90)
reference = make_fe.reference_frf(f, 0.02, 5.0e4, 2.0)
responses = {}
for two_sided in (True, False):
    body = reduce_modal(fe, modes=12, two_sided=two_sided, keep_nodes=[1], store_bases=True)
    save_reduced_body(attach_invariants(body, fe), work / "body.npz")
    module = load_description_module(work / "model.yaml")
    lin = linearize(module)
    responses[two_sided] = frequency_response(lin, f, "F", "mass_x").H[:, 0, 0]
    error = np.abs(responses[two_sided] - reference) / np.abs(reference)
    side = "two-sided" if two_sided else "one-sided"
    print(f"{side}: order {body.order}, max error {error.max():.1e}, median {np.median(error):.1e}")

assert np.max(np.abs(responses[True] - reference) / np.abs(reference)) < 0.03

# %%
fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
ax.semilogy(f, np.abs(reference), "k", lw=3, alpha=0.4, label="unreduced FE model (102 DOFs)")
ax.semilogy(f, np.abs(responses[True]), label="two-sided, 12 modes")
ax.semilogy(f, np.abs(responses[False]), "--", label="one-sided, 12 modes")
ax.set_xlabel("frequency [Hz]")
ax.set_ylabel("|mass_x / F| [m/N]")
ax.legend()
