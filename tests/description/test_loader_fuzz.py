"""Fuzzing the description pipeline.

Mutated shipped descriptions (tests/support/fuzz_inputs.py) are loaded, derived, generated, imported
and evaluated. Property: a NeweulError with one line, or a result — never another exception.
Reference: the error hierarchy of neweul_py/errors.py. Bounded in CI (``max_examples``);
``NEWEUL_FUZZ_LONG=1`` runs 20× longer, benchmarks/bench_fuzz.py ≥ 10 000 cases.
"""

from __future__ import annotations

import numpy as np
from fuzz_inputs import dump, fuzz_settings, mutate_tree, outcome, seed_trees
from hypothesis import given
from hypothesis import strategies as st

from neweul_py.description import load_description_text

TREES = seed_trees()
NAMES = sorted(TREES)


def _text(name: str, rng, plausible: bool = False) -> str | None:
    try:
        return dump(mutate_tree(TREES[name], rng, plausible=plausible))
    except (RecursionError, ValueError):
        return None


@fuzz_settings(150)
@given(st.sampled_from(NAMES), st.randoms(use_true_random=False))
def test_mutated_descriptions_load_or_fail_cleanly(name, rng):
    text = _text(name, rng)
    if text is not None:
        outcome(lambda: load_description_text(text, f"{name}.yaml"))


def _generate_and_evaluate(text: str, name: str, tmp: str) -> None:
    from neweul_py.analysis.module import check_protocol
    from neweul_py.cache import import_verified
    from neweul_py.codegen import render_module
    from neweul_py.equations import newton_euler

    system = load_description_text(text, f"{name}.yaml")
    if not system.coordinates:
        return
    source = render_module(newton_euler(system), "0" * 64).encode()
    module = import_verified(f"{tmp}/{name}.py", source)
    check_protocol(module)
    x0 = np.asarray(module.INITIAL_STATE, dtype=float)
    p = module.default_parameters()
    u = module.default_inputs(0.0, p)
    with np.errstate(all="ignore"):
        try:
            module.rhs(0.0, x0, p, u)
            module.outputs(0.0, x0, p, u)
        except (ArithmeticError, np.linalg.LinAlgError):
            pass  # the analysis layer turns these into SolverError (tests/commands)


@fuzz_settings(25)
@given(st.sampled_from(NAMES), st.randoms(use_true_random=False))
def test_mutated_descriptions_generate_import_and_evaluate(tmp_path_factory, name, rng):
    text = _text(name, rng, plausible=True)
    if text is not None:
        tmp = tmp_path_factory.mktemp("gen")
        outcome(lambda: _generate_and_evaluate(text, name, str(tmp)))
