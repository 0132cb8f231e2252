"""The piston–duct u–p model of ``examples/elastic_up_body`` with loss factors, shared by the
loss-factor tests of the reductors and of the compiled backend."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import scipy.sparse as sps

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "elastic_up_body"
ETA_PISTON, ETA_AIR, F_REF = 0.05, 0.02, 300.0


def make_fe() -> ModuleType:
    """``examples/elastic_up_body/make_fe.py`` as a module."""
    spec = importlib.util.spec_from_file_location("elastic_up_make_fe", EXAMPLE / "make_fe.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def lossy_duct(f_ref: float = F_REF):
    """The piston–duct model with loss factors: ``G = blockdiag(η_p k_p, η_air Kf)``, and
    ``D = G/ω_ref`` its time-domain equivalent (as the middle-ear working points)."""
    fe = make_fe().piston_duct()
    G = sps.block_diag([sps.csr_matrix([[ETA_PISTON * fe.K[0, 0]]]), ETA_AIR * fe.K[1:, 1:]],
                       format="csr")
    return fe.with_(G=G, loss_reference_frequency=f_ref, D=G / (2 * np.pi * f_ref))
