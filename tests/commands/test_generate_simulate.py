"""``neweul generate`` and ``neweul simulate`` end to end through ``neweul_py.cli.main``.

References: the shipped ``generated/`` modules (byte-identical output), the Python API
(same numbers), and the issue's file formats; errors exit 1 with one readable line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from neweul_py import api
from neweul_py.cli import main
from neweul_py.errors import DescriptionError
from neweul_py.yaml_tree import read_description

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"


@pytest.fixture(autouse=True)
def _cache(tmp_path, monkeypatch):
    monkeypatch.setenv("NEWEUL_CACHE", str(tmp_path / "cache"))


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_generate_writes_the_shipped_module(capsys, tmp_path):
    code, out, _ = _run(capsys, "generate", str(EXAMPLES / "pendulum.yaml"), "-o",
                        str(tmp_path / "gen"))
    assert code == 0
    written = tmp_path / "gen" / "pendulum.py"
    assert out.strip() == str(written)
    assert written.read_bytes() == (ROOT / "generated" / "pendulum.py").read_bytes()


def test_generate_forms(capsys, tmp_path):
    for form in ("closed", "recursive"):
        code, _, _ = _run(capsys, "generate", str(EXAMPLES / "double_pendulum.yaml"), "-o",
                          str(tmp_path / form), "--form", form)
        assert code == 0
    from neweul_py.analysis.module import load_generated

    closed = load_generated(tmp_path / "closed" / "double_pendulum.py")
    recursive = load_generated(tmp_path / "recursive" / "double_pendulum.py")
    x = np.array([0.3, -0.7, 1.1, 0.4])
    p = closed.default_parameters()
    np.testing.assert_allclose(recursive.rhs(0.0, x, p), closed.rhs(0.0, x, p), rtol=1e-12)


def test_simulate_writes_csv_and_plot(capsys, tmp_path):
    csv = tmp_path / "out" / "dp.csv"
    png = tmp_path / "out" / "dp.png"
    argv = ["simulate", str(EXAMPLES / "double_pendulum.yaml"), "--t-end", "1",
            "--n-out", "11", "-o", str(csv)]
    if _has_matplotlib():
        argv += ["--plot", str(png)]
    code, out, err = _run(capsys, *argv)
    assert code == 0, err
    assert "double_pendulum" in out
    lines = csv.read_text().splitlines()
    assert lines[0] == "t,phi1,phi2,d_phi1,d_phi2,tip_x,tip_z,z_rod1,z_rod2"
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    ref = api.simulate_description(EXAMPLES / "double_pendulum.yaml", 1.0, n_out=11)
    np.testing.assert_allclose(data, ref.table, rtol=1e-12, atol=1e-12)
    if _has_matplotlib():
        assert png.read_bytes()[:4] == b"\x89PNG"


def test_simulate_npz_method_and_parameter(capsys, tmp_path):
    npz = tmp_path / "p.npz"
    code, _, err = _run(capsys, "simulate", str(EXAMPLES / "pendulum.yaml"), "--t-end", "0.5",
                        "--method", "Radau", "-p", "l=1.0", "-o", str(npz))
    assert code == 0, err
    with np.load(npz, allow_pickle=False) as data:
        assert str(data["method"]) == "Radau"
        assert dict(zip(data["parameter_names"], data["parameter_values"],
                        strict=True))["l"] == 1.0


def test_simulate_generated_module_directly(capsys):
    code, out, _ = _run(capsys, "simulate", str(ROOT / "generated" / "heavy_top.py"),
                        "--t-end", "0.1")
    assert code == 0
    assert "final state: alpha = " in out


def test_simulate_reuses_the_cache(tmp_path, monkeypatch):
    first = api.generated_module(EXAMPLES / "pendulum.yaml")
    assert first.parent == tmp_path / "cache"

    def fail(*args, **kwargs):
        raise AssertionError("regenerated although the description is unchanged")

    monkeypatch.setattr(api, "_derive_tree", fail)
    assert api.generated_module(EXAMPLES / "pendulum.yaml") == first


def test_changed_description_is_regenerated(tmp_path):
    src = tmp_path / "pendulum.yaml"
    text = (EXAMPLES / "pendulum.yaml").read_text()
    src.write_text(text)
    first = api.generated_module(src)
    src.write_text(text.replace("g: 9.81", "g: 1.62"))
    second = api.generated_module(src)
    assert first != second
    assert "'g': 1.62" in second.read_text()


@pytest.mark.parametrize(
    ("yaml_text", "message"),
    [
        ("name: m\nbodies: {b: {frame: nowhere, mass: 1}}\ncoordinates: {x: 0}\n",
         "bodies.b.frame"),
        ("name: m\nparameters: {a: __import__('os')}\n", "parameters.a"),
        ("name: [unclosed\n", "m.yaml"),
        ("name: m\nframes: {box: {}}\nbodies: {b: {frame: box, mass: 1}}\n",
         "m.yaml: coordinates: the model has no coordinates"),
    ],
)
def test_bad_description_is_one_line_exit_1(capsys, tmp_path, yaml_text, message):
    src = tmp_path / "m.yaml"
    src.write_text(yaml_text)
    for cmd in (["generate", str(src), "-o", str(tmp_path / "gen")],
                ["simulate", str(src), "--t-end", "1"]):
        code, _out, err = _run(capsys, *cmd)
        assert code == 1
        assert err.count("\n") == 1 and err.startswith(f"neweul {cmd[0]}: error: ")
        assert message in err
        assert "Traceback" not in err
    assert not (tmp_path / "gen").exists()


def test_failed_generation_keeps_previous_module(capsys, tmp_path):
    src = tmp_path / "pendulum.yaml"
    good = (EXAMPLES / "pendulum.yaml").read_text()
    src.write_text(good)
    assert _run(capsys, "generate", str(src), "-o", str(tmp_path))[0] == 0
    module = tmp_path / "pendulum.py"
    before = module.read_bytes()
    src.write_text(good.replace("mass: m", "mass: -m"))
    code, _, err = _run(capsys, "generate", str(src), "-o", str(tmp_path))
    assert code == 1 and "mass" in err
    assert module.read_bytes() == before


def test_simulate_argument_errors(capsys, tmp_path):
    code, _, err = _run(capsys, "simulate", str(EXAMPLES / "pendulum.yaml"), "--t-end", "1",
                        "-o", str(tmp_path / "x.txt"))
    assert code == 1 and ".csv or .npz" in err
    code, _, err = _run(capsys, "simulate", str(EXAMPLES / "pendulum.yaml"), "--t-end", "1",
                        "-p", "length=2")
    assert code == 1 and "unknown parameter 'length'" in err
    code, _, err = _run(capsys, "simulate", str(tmp_path / "missing.yaml"), "--t-end", "1")
    assert code == 1 and "missing.yaml" in err


def _has_matplotlib() -> bool:
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def test_cache_key_follows_referenced_data_files(tmp_path):
    """A module generated from a description with elastic-body data must be regenerated when
    the data file changes, even if the description's text does not."""
    src = tmp_path / "m.yaml"
    src.write_text("name: m\nelastic_bodies:\n  beam: {frame: f, data: beam.npz}\n")
    (tmp_path / "beam.npz").write_bytes(b"one")
    first = api._data_fingerprints(read_description(src.read_bytes()).data, src)
    (tmp_path / "beam.npz").write_bytes(b"two")
    second = api._data_fingerprints(read_description(src.read_bytes()).data, src)
    assert first != second and len(first) == 1
    assert api._data_fingerprints(["not", "a", "mapping"], src) == []


def test_description_is_parsed_once_per_generation(tmp_path, monkeypatch):
    """A cache miss reads and parses the YAML once for the cache key and the derivation
    alike (reference: a count of the parser's calls); malformed YAML is one error with its
    line, before any key is formed."""
    import neweul_py.yaml_tree as yaml_tree

    calls = []
    original = yaml_tree.read_yaml

    def counting(*args, **kwargs):
        calls.append(args[1] if len(args) > 1 else kwargs.get("file"))
        return original(*args, **kwargs)

    monkeypatch.setattr(yaml_tree, "read_yaml", counting)
    src = tmp_path / "pendulum.yaml"
    src.write_text((EXAMPLES / "pendulum.yaml").read_text())
    api.generated_module(src, cache=tmp_path / "cache")
    assert calls == [str(src)]
    calls.clear()
    api.generate(src, tmp_path / "out", cache=tmp_path / "cache2")
    assert calls == [str(src)]
    src.write_text("name: [\n")
    with pytest.raises(DescriptionError, match=r"pendulum.yaml:2.*malformed YAML"):
        api.generated_module(src, cache=tmp_path / "cache")


def test_negative_number_lists_are_option_values():
    """`--values -4000,0,4000`, `--pressures -4000:4000:9` and `--f -1:2:3`-like words are
    values, not unknown options; a real option after them still parses."""
    from neweul_py.cli import build_parser

    parser = build_parser()
    args = parser.parse_args(["interpolate", "a.npz", "b.npz", "c.npz", "--parameter", "dp",
                              "--values", "-4000,0,4000", "-o", "x.npz"])
    assert list(args.values) == [-4000.0, 0.0, 4000.0]
    args = parser.parse_args(["fem", "middle-ear", "--pressures", "-4000:4000:9", "-o", "d"])
    assert args.pressures.values() == [float(v) for v in range(-4000, 4001, 1000)]
    assert args.output == "d"
