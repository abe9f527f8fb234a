"""The scenario key reference, generated from the scenario schema
(:class:`hil.scenario.schema.Scenario`).

Every key a scenario TOML file accepts comes from the msgspec Structs of
:mod:`hil.scenario.schema`; msgspec derives their JSON Schema (types, ranges, defaults, which keys
are required), and this module writes it out as one Markdown table per section, with the
section's docstring as its text. The docs page ``docs/guide/scenario-keys.md`` is this
module's output (``python -m hil.scenario.reference > docs/guide/scenario-keys.md``); a test
checks that the page is up to date, so the reference cannot drift from the code.
"""

from __future__ import annotations

import inspect
import json
import re
import sys
from typing import Any

import msgspec

from hil.scenario import schema as sc

#: Sections in the order a scenario file is usually written, with the TOML path they sit at.
_SECTIONS: tuple[tuple[str, str], ...] = (
    ("Scenario", "top level"),
    ("SteadyWindSpec", '[wind] kind = "steady"'),
    ("StepWindSpec", '[wind] kind = "step"'),
    ("RampWindSpec", '[wind] kind = "ramp"'),
    ("TurbulentWindSpec", '[wind] kind = "turbulent"'),
    ("GustWindSpec", '[wind] kind = "gust"'),
    ("JonswapWavesSpec", '[waves] kind = "jonswap"'),
    ("PiersonMoskowitzWavesSpec", '[waves] kind = "pierson_moskowitz"'),
    ("IsscWavesSpec", '[waves] kind = "issc"'),
    ("StillWavesSpec", '[waves] kind = "still"'),
    ("TimingSection", "[timing]"),
    ("SensorSection", "[sensors]"),
    ("ControllerSection", "[controller]"),
    ("FaultSection", "[[faults]] (one table per fault)"),
    ("CanSection", "[can]"),
    ("ReviewSection", "[review]"),
    ("InitialSection", "[initial]"),
    ("RecordingSection", "[recording]"),
)


def _type_text(prop: dict[str, Any], defs: dict[str, Any]) -> str:
    """A short human form of one property's schema (type, allowed values)."""
    if "$ref" in prop:
        name = prop["$ref"].rsplit("/", 1)[-1]
        return f"table ({name})"
    if "anyOf" in prop:
        parts = [_type_text(p, defs) for p in prop["anyOf"]]
        if "discriminator" in prop:
            kinds = ", ".join(f'"{k}"' for k in prop["discriminator"]["mapping"])
            return f"table, kind = one of {kinds}"
        return " or ".join(dict.fromkeys(parts))
    if "enum" in prop:
        return "one of " + ", ".join(json.dumps(v) for v in prop["enum"])
    if "const" in prop:
        return json.dumps(prop["const"])
    kind = prop.get("type", "any")
    if kind == "array":
        return f"list of {_type_text(prop.get('items', {}), defs)}"
    if kind == "object":
        extra = prop.get("additionalProperties")
        return f"table of {_type_text(extra, defs)}" if isinstance(extra, dict) else "table"
    return {"number": "number", "integer": "integer", "string": "string", "boolean": "bool"}.get(
        kind, str(kind)
    )


def _range_text(prop: dict[str, Any]) -> str:
    """``[lo, hi]`` style bounds of a number (exclusive bounds in parentheses), or ""."""
    lo = prop.get("minimum", prop.get("exclusiveMinimum"))
    hi = prop.get("maximum", prop.get("exclusiveMaximum"))
    if lo is None and hi is None:
        pattern = prop.get("pattern")
        return f"matches `{pattern}`" if pattern else ""
    left = "(" if "exclusiveMinimum" in prop else "["
    right = ")" if "exclusiveMaximum" in prop else "]"
    return f"{left}{_num(lo, '-inf')}, {_num(hi, 'inf')}{right}"


def _num(x: float | None, none: str) -> str:
    """A bound as written in a scenario file: integers whole, floats short."""
    if x is None:
        return none
    return str(x) if isinstance(x, int) else f"{x:g}"


def _default_text(name: str, prop: dict[str, Any], required: set[str]) -> str:
    if name in required:
        return "required"
    if "default" not in prop:
        return "(section defaults)"
    return f"`{json.dumps(prop['default'])}`"


def _doc(name: str) -> str:
    cls = getattr(sc, name, None)
    return inspect.cleandoc(cls.__doc__) if cls is not None and cls.__doc__ else ""


def markdown() -> str:
    """The whole reference page (Markdown)."""
    schema = msgspec.json.schema(sc.Scenario)
    defs: dict[str, Any] = schema["$defs"]
    out = [
        "# Scenario key reference",
        "",
        "Generated from the scenario schema (`hil/scenario/schema.py`) by",
        "`python -m hil.scenario.reference`; do not edit by hand. Every key carries its unit",
        "in its name (`_s`, `_m`, `_m_s`, `_rad`, ...). An unknown key, a value outside its",
        "range, NaN or infinity is refused with the key's path and what was expected. The",
        "guide's [scenarios page](scenarios.md) shows whole files.",
        "",
    ]
    for name, where in _SECTIONS:
        d = defs.get(name)
        if d is None:
            continue
        out += [f"## {where}", ""]
        doc = _doc(name)
        if doc:
            # Sphinx roles (:class:`x`) and double backticks read as plain code here.
            out += [re.sub(r":[a-z]+:`([^`]+)`", r"`\1`", doc.replace("``", "`")), ""]
        out += ["| key | type | range | default |", "| --- | --- | --- | --- |"]
        required = set(d.get("required", ()))
        for key, prop in d.get("properties", {}).items():
            cells = (
                f"`{key}`",
                _type_text(prop, defs).replace("|", "\\|"),
                _range_text(prop).replace("|", "\\|"),
                _default_text(key, prop, required),
            )
            out.append("| " + " | ".join(cells) + " |")
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    sys.stdout.write(markdown())
