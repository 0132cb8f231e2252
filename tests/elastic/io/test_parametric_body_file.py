"""Parametric body files in the compact layout of version 9: a stack's base and the entries
that vary, the matrices' slopes and curvatures in single precision
(neweul_py/elastic/io/body_files.py, layout.py; docs/reduced-body-format.md).

Reference: the body written — read back, every value, slope and curvature is within the
documented bound (1e-13 of its entry's scale; the values' scale over the sampled range for
slopes, over its square for curvatures; plus 2⁻²⁴ of the entry for the slopes and curvatures
of M, D, K, G) — and the block structure the body is built with
(the u–p structure of the middle ear: the structural rows vary, the pressure block varies at
round-off, the block below the structure is zero).
"""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from neweul_py.commands.body_info import _parts
from neweul_py.elastic.bodies.parametric import ParametricBody
from neweul_py.elastic.io.body_files import load_parametric_body, save_parametric_body
from neweul_py.elastic.io.npz import json_to_uint8, save_npz_atomic
from neweul_py.ffrf.varying import VARYING_TOLERANCE, entry_scale, ffrf_expand

K, NU, NP = 5, 6, 3
R = NU + NP
STEP = 250.0


def _up(rng: np.random.Generator, pressure: float) -> np.ndarray:
    """(K, R, R): structural rows that vary, a pressure block of entries ~``pressure`` that
    varies at round-off, zero below the structure."""
    base = np.zeros((R, R))
    base[:NU] = 1e-3 * rng.standard_normal((NU, R))
    base[NU:, NU:] = pressure * (2.0 + rng.standard_normal((NP, NP)))
    s = np.repeat(base[None], K, axis=0)
    s[:, :NU] += 1e-5 * rng.standard_normal((K, NU, R))
    s[:, NU:, NU:] *= 1.0 + 1e-16 * rng.standard_normal((K, NP, NP))
    return s


def _derivative(rng: np.random.Generator, like: np.ndarray) -> np.ndarray:
    """Slopes or curvatures: nonzero in the structural rows only."""
    d = np.zeros_like(like)
    d[:, :NU] = 1e-8 * rng.standard_normal(d[:, :NU].shape)
    return d


@pytest.fixture(scope="module")
def body() -> ParametricBody:
    rng = np.random.default_rng(7)
    M, Kst, G = _up(rng, 1.0), _up(rng, 1e12), _up(rng, 1e10)
    stacks = {"M": M, "K": Kst, "G": G, "D": G / (2 * np.pi * 1000.0),
              "B": np.repeat(rng.standard_normal((1, R, 1)), K, axis=0),
              "C": _up(rng, 1.0)[:, :1, :],
              "V_kept": np.repeat(rng.standard_normal((1, 3, R)), K, axis=0),
              "W_kept": np.repeat(rng.standard_normal((1, 3, R)), K, axis=0)}
    slopes = {key: _derivative(rng, a) for key, a in stacks.items()}
    curvatures = {key: _derivative(rng, a) for key, a in stacks.items()}
    for d in (slopes, curvatures):                # D = G/ω_ref, its slopes likewise
        d["D"] = d["G"] / (2 * np.pi * 1000.0)
    eye = np.repeat(np.eye(R)[None], K, axis=0)
    basis = np.zeros((12, R))                  # u–p block-diagonal: pressure rows, columns
    basis[:8, :NU], basis[8:, NU:] = rng.standard_normal((8, NU)), rng.standard_normal((4, NP))
    return ParametricBody(
        parameter="dp", samples=STEP * np.arange(K), **stacks, loss_reference_frequency=1000.0,
        input_names=("f",), output_names=("y",), nodes=np.array([[1.0, 0.0, 0.0, 0.0]]),
        kept_dofs=np.arange(3), dof_node=np.ones(3, dtype=int),
        dof_kind=np.array(["ux", "uy", "uz"]), T=eye, L=eye,
        R=basis, singular_values=np.ones(R), svd_weights=np.ones(K),
        basis="full", two_sided=False, interpolation="quintic-hermite", slopes=slopes,
        curvatures=curvatures)


def _meta(path: Path) -> dict:
    with np.load(path) as z:
        return json.loads(z["meta"].tobytes())


def test_read_back_within_the_documented_bound(body, tmp_path: Path) -> None:
    """Values, slopes and curvatures read back within ``1e-13 · scale`` entry by entry (the
    varying rows bit for bit), the slopes and curvatures of ``M``, ``D``, ``K``, ``G``
    within ``2⁻²⁴`` of each entry more (single precision); the u–p matrices are stored as
    their varying rows, ``D`` (``G/ω_ref``) as the factor of ``G``."""
    path = tmp_path / "b.npz"
    save_parametric_body(body, path)
    back = load_parametric_body(path)
    meta = _meta(path)
    assert meta["version"] == 9 and meta["layout"]["tolerance"] == VARYING_TOLERANCE
    for key in ("M", "K", "G", "slope/K", "curvature/M"):
        assert key in meta["layout"]["varying"], key
    for prefix in ("", "slope/", "curvature/"):               # D = G/ω_ref: not stored
        assert meta["layout"]["scaled"][prefix + "D"] == [prefix + "G",
                                                          1 / (2 * np.pi * 1000.0)]
    span = body.samples[-1] - body.samples[0]
    for key in ("M", "K", "G", "D", "C"):
        scale = VARYING_TOLERANCE * entry_scale(body.stack(key))
        single = 2.0**-24 if key != "C" else 0.0
        for got, want, factor, rounding in (
                (back.stack(key), body.stack(key), 1.0, 0.0),
                (back.slopes[key], body.slopes[key], 1 / span, single),
                (back.curvatures[key], body.curvatures[key], 1 / span**2, single)):
            assert got.dtype == np.float64, key
            assert np.all(np.abs(got - want) <= factor * scale + rounding * np.abs(want)), key
            if key != "D":
                assert np.array_equal(got[:, :NU], want[:, :NU]) == (rounding == 0), key
    with np.load(path) as z:
        assert z["slope/K@values"].dtype == np.float32 and z["K@values"].dtype == np.float64
    with zipfile.ZipFile(path) as z:
        sizes = {i.filename[:-4]: i.file_size for i in z.infolist()}
    assert sizes["K@values"] < 8 * K * NU * R + 256        # the structural rows only
    # the structural rows: the Hermite weights of the slopes and curvatures are below h
    # and h² (0 at a sample)
    bound = 2.0**-24 * (STEP * np.abs(body.slopes["K"]).max()
                        + STEP**2 * np.abs(body.curvatures["K"]).max())
    for p in (STEP, 300.0):
        assert np.abs(back.at(p).K[:NU] - body.at(p).K[:NU]).max() <= bound
    assert meta["layout"]["sparse"]["R"] == [12, R] and np.array_equal(back.R, body.R)


def test_body_info_counts_every_stored_byte_in_its_part(body, tmp_path: Path) -> None:
    """``neweul body-info``'s sizes by part add up to the stored members, the varying
    members counted with their stack (reference: the zip's own member sizes)."""
    path = tmp_path / "b.npz"
    save_parametric_body(body, path)
    lines = _parts(str(path))
    with zipfile.ZipFile(path) as z:
        total = sum(i.file_size for i in z.infolist())
    parts = {line.split(":")[0].strip(): float(line.split(":")[1].split()[0])
             for line in lines[1:]}
    assert abs(sum(parts.values()) - total / 1e6) < 0.01 * len(parts)
    assert "stored as their varying entries" in lines[0]
    assert parts["matrices M, D, K, G"] > 0 and parts["slopes"] > 0


def test_a_version_6_file_still_reads(body, tmp_path: Path) -> None:
    """The same body written in the layout of version 6 (every stack and matrix in full)
    reads back equal to the version-7 file (reference: the version-7 read-back)."""
    new = tmp_path / "b7.npz"
    save_parametric_body(body, new)
    seven = load_parametric_body(new)
    with np.load(new) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(arrays.pop("meta").tobytes())
    for key, shape in meta["layout"].pop("sparse").items():      # matrices in full
        dense = np.zeros(shape)
        dense.reshape(-1)[np.flatnonzero(np.unpackbits(arrays.pop(key + "@nonzero"),
                                                       count=dense.size))] = arrays[key]
        arrays[key] = dense
    for key in meta["layout"].pop("scaled"):                  # D in full
        what, _, name = key.rpartition("/")
        arrays[key] = ({"": seven.stack, "slope": seven.slopes.get,
                        "curvature": seven.curvatures.get}[what](name))
    for key in meta["layout"].pop("varying"):
        index = np.flatnonzero(np.unpackbits(arrays.pop(key + "@mask"),
                                             count=arrays[key].size))
        arrays[key] = ffrf_expand(arrays[key], np.ones(K), index, arrays.pop(key + "@values"))
    del meta["layout"]["tolerance"]
    meta["version"] = 6
    arrays["meta"] = json_to_uint8(meta)
    save_npz_atomic(tmp_path / "b6.npz", arrays)
    six = load_parametric_body(tmp_path / "b6.npz")
    for key in ("M", "K", "G", "D", "C"):
        assert np.array_equal(six.stack(key), seven.stack(key))
        assert np.array_equal(six.slopes[key], seven.slopes[key])
        assert np.array_equal(six.curvatures[key], seven.curvatures[key])


def test_symmetric_blocks_store_their_upper_triangle(body, tmp_path: Path) -> None:
    """A stack whose varying structural block is symmetric (the membrane of a Galerkin
    body) stores the entries on and above the diagonal and ``<key>@mirror``; read back,
    every entry is within the documented bound and the block symmetric. A version-7 file
    with such a member, or mirror bits on or above the diagonal, is one DataError
    (reference: the stack written)."""
    from neweul_py.errors import DataError

    def sym(a: np.ndarray) -> np.ndarray:
        a = a.copy()
        a[:, :NU, :NU] = 0.5 * (a[:, :NU, :NU] + a[:, :NU, :NU].transpose(0, 2, 1))
        return a

    b = body.with_(K=sym(body.K), slopes={**body.slopes, "K": sym(body.slopes["K"])})
    plain, mirrored = tmp_path / "plain.npz", tmp_path / "sym.npz"
    save_parametric_body(body, plain)
    save_parametric_body(b, mirrored)
    with zipfile.ZipFile(mirrored) as z:
        names = {i.filename[:-4]: i.file_size for i in z.infolist()}
    assert "K@mirror" in names and "slope/K@mirror" in names
    with zipfile.ZipFile(plain) as z:
        assert names["K@values"] < {i.filename[:-4]: i.file_size
                                    for i in z.infolist()}["K@values"]
    back = load_parametric_body(mirrored)
    span = b.samples[-1] - b.samples[0]
    scale = VARYING_TOLERANCE * entry_scale(b.K)
    assert np.all(np.abs(back.K - b.K) <= scale)
    assert np.all(np.abs(back.slopes["K"] - b.slopes["K"])
                  <= scale / span + 2.0**-24 * np.abs(b.slopes["K"]))
    np.testing.assert_array_equal(back.K[:, :NU, :NU], back.K[:, :NU, :NU].transpose(0, 2, 1))
    with np.load(mirrored) as z:
        data = {k: z[k] for k in z.files}
    meta = json.loads(data["meta"].tobytes())
    double = {k: v.astype(np.float64) for k, v in data.items() if v.dtype == np.float32}
    for n, (version, members, words) in enumerate((
            (7, double, "version-7 file holds no mirrored"),
            (9, {"K@mirror": np.full_like(data["K@mirror"], 255)}, "below its diagonal"),
            (9, {"K@mirror": data["K@mask"]}, "is not stored"),
            (9, {"B@mirror": data["K@mirror"]}, "belongs to no varying array"),
            (8, {}, "float32 from version 9"),
            (9, {"slope/K@values": data["slope/K@values"].astype(np.float16)}, "float16"),
            (9, {"K@values": data["K@values"].astype(np.float32)}, "holds float64"))):
        bad = tmp_path / f"bad{n}.npz"
        save_npz_atomic(bad, {**data, **members,
                              "meta": json_to_uint8({**meta, "version": version})})
        with pytest.raises(DataError, match=words):
            load_parametric_body(bad)
