"""A model at a glance in notebooks: ``System._repr_html_`` and ``_repr_markdown_``.

One table per part of the model that it has — parameters with their defaults, coordinates
with their initial values and velocities, inputs with their default excitation, rigid and
elastic bodies, force elements, constraints, outputs — under the model's name and
description.
"""

from __future__ import annotations

import html
from typing import Any

__all__ = ["system_html", "system_markdown", "system_tables"]


def _text(value: Any) -> str:
    return " ".join(str(value).split())


def system_tables(system: Any) -> list[tuple[str, list[str], list[list[str]]]]:
    """``(title, header, rows)`` of each non-empty part of ``system``."""
    tables = [
        ("parameters", ["name", "default"],
         [[p.name, f"{p.default:.6g}"] for p in system.parameters]),
        ("coordinates", ["name", "initial", "velocity"],
         [[c.name, f"{c.initial:.6g}", f"{c.velocity:.6g}"] for c in system.coordinates]),
        ("inputs", ["name", "default excitation"],
         [[i.name, _text(i.default)] for i in system.inputs]),
        ("bodies", ["name", "frame", "mass"],
         [[b.name, b.frame, _text(b.mass)] for b in system.bodies]),
        ("elastic bodies", ["name", "frame", "elastic coordinates"],
         [[b.name, b.frame, str(b.nq)] for b in system.elastic_bodies]),
        ("force elements", ["name", "type"],
         [[f.name, type(f).__name__] for f in system.forces]),
        ("constraints", ["name", "type"],
         [[c.name, type(c).__name__] for c in system.constraints]),
        ("outputs", ["name", "type"],
         [[o.name, type(o).__name__] for o in system.outputs]),
    ]
    return [t for t in tables if t[2]]


def _title(system: Any) -> str:
    return (f"model {system.name}: {len(system.coordinates)} coordinates, "
            f"{len(system.bodies)} bodies, {len(system.elastic_bodies)} elastic bodies")


def system_markdown(system: Any) -> str:
    """The model as Markdown: a title line, its description, one table per part."""
    lines = [f"**{_title(system)}**", ""]
    if system.description:
        lines += [_text(system.description), ""]
    for title, header, rows in system_tables(system):
        lines += [f"*{title}*", "", "| " + " | ".join(header) + " |",
                  "|" + "---|" * len(header)]
        lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |"
                  for row in rows]
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"


def system_html(system: Any) -> str:
    """The model as HTML (escaped): a title, its description, one table per part."""
    esc = html.escape
    out = [f"<div><p><b>{esc(_title(system))}</b></p>"]
    if system.description:
        out.append(f"<p>{esc(_text(system.description))}</p>")
    for title, header, rows in system_tables(system):
        head = "".join(f"<th>{esc(h)}</th>" for h in header)
        body = "".join("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in row) + "</tr>"
                       for row in rows)
        out.append(f"<p><i>{esc(title)}</i></p><table><thead><tr>{head}</tr></thead>"
                   f"<tbody>{body}</tbody></table>")
    out.append("</div>")
    return "".join(out)
