"""A model at a glance in notebooks (model/display.py, ``System._repr_html_``).

Reference: the model's own items — every parameter with its default, every coordinate,
input, body, force element, constraint and output appears, escaped in HTML.
"""

from __future__ import annotations

from pathlib import Path

import neweul_py

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_every_item_of_the_model_is_shown():
    system = neweul_py.load_description(EXAMPLES / "four_bar.yaml")
    md, page = system._repr_markdown_(), system._repr_html_()
    assert md.startswith("**model four_bar: 3 coordinates, 3 bodies, 0 elastic bodies**")
    for p in system.parameters:
        assert f"| {p.name} | {p.default:.6g} |" in md
        assert f"<td>{p.name}</td><td>{p.default:.6g}</td>" in page
    for item in (*system.coordinates, *system.inputs, *system.bodies, *system.forces,
                 *system.constraints, *system.outputs):
        assert f"| {item.name} |" in md and f"<td>{item.name}</td>" in page
    assert "<td>RotationalSpringDamper</td>" in page and "*constraints*" in md


def test_html_is_escaped():
    """Free text of the description reaches the page as text, not markup."""
    from neweul_py.description import load_description_text

    system = load_description_text(
        "name: tags\ndescription: '<script>x</script> & more'\ncoordinates: {q: 0}\n"
        "frames: {f: {translation: [q, 0, 0]}}\nbodies: {b: {frame: f, mass: 1}}\n", "t.yaml")
    page = system._repr_html_()
    assert "<script>" not in page and "&lt;script&gt;x&lt;/script&gt; &amp; more" in page
