"""Scenarios: TOML files that say what a run is, validated on load.

A scenario names the turbine preset, the controller and its preset, the wind, the sensor
noise, the timing (control period, plant step) and the run length. Every key carries its
unit in its name (``duration_s``, ``speed_m_s``); a misspelt key or a key with another unit
is an error naming the key and, where it looks like a known key with another unit, the key
that was meant. Shipped scenarios live in ``hil/scenarios/*.toml``.
"""

from __future__ import annotations

import difflib
import importlib.resources
import re
import tomllib
from pathlib import Path
from typing import Annotated, Literal

import msgspec

Positive = Annotated[float, msgspec.Meta(gt=0.0)]
NonNegative = Annotated[float, msgspec.Meta(ge=0.0)]
WindSpeed = Annotated[float, msgspec.Meta(ge=0.0, le=70.0)]


class ScenarioError(ValueError):
    """A scenario file that cannot be used, with the key at fault in the message."""


class _Section(msgspec.Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    pass


class SteadyWindSpec(
    _Section, frozen=True, forbid_unknown_fields=True, kw_only=True, tag="steady", tag_field="kind"
):
    """Constant hub-height wind."""

    speed_m_s: WindSpeed


class StepWindSpec(
    _Section, frozen=True, forbid_unknown_fields=True, kw_only=True, tag="step", tag_field="kind"
):
    """A step from ``initial_m_s`` to ``final_m_s`` at ``time_s``."""

    initial_m_s: WindSpeed
    final_m_s: WindSpeed
    time_s: NonNegative


class RampWindSpec(
    _Section, frozen=True, forbid_unknown_fields=True, kw_only=True, tag="ramp", tag_field="kind"
):
    """A linear ramp from ``initial_m_s`` at ``start_s`` to ``final_m_s`` at ``end_s``."""

    initial_m_s: WindSpeed
    final_m_s: WindSpeed
    start_s: NonNegative
    end_s: NonNegative


WindSpecSection = SteadyWindSpec | StepWindSpec | RampWindSpec


class TimingSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Rates of the loop.

    ``control_period_s`` is both the sensor frame period and the command deadline;
    ``plant_step_s`` is the fixed internal integration step and must divide it.
    """

    control_period_s: Positive = 0.01
    plant_step_s: Positive = 0.01


class SensorSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """White measurement noise (standard deviations) and the noise seed."""

    seed: int = 1
    generator_speed_std_rad_s: NonNegative = 0.0
    blade_pitch_std_rad: NonNegative = 0.0
    generator_torque_std_nm: NonNegative = 0.0
    electrical_power_std_w: NonNegative = 0.0
    wind_speed_std_m_s: NonNegative = 0.0


class ControllerSection(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Which controller runs and with which parameter preset."""

    kind: Literal["baseline"] = "baseline"
    preset: str = "nrel5mw_baseline"


class Scenario(_Section, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """One run of the bench."""

    name: str
    turbine: str
    wind: WindSpecSection
    description: str = ""
    turbine_id: Annotated[str, msgspec.Meta(pattern=r"^[A-Za-z0-9_-]+$")] = "t1"
    duration_s: Positive = 60.0
    timing: TimingSection = msgspec.field(default_factory=TimingSection)
    sensors: SensorSection = msgspec.field(default_factory=SensorSection)
    controller: ControllerSection = msgspec.field(default_factory=ControllerSection)

    def __post_init__(self) -> None:
        ratio = self.timing.control_period_s / self.timing.plant_step_s
        if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
            raise ValueError(
                f"timing.plant_step_s = {self.timing.plant_step_s} must divide "
                f"timing.control_period_s = {self.timing.control_period_s}"
            )
        if self.timing.control_period_s > 1.0:
            raise ValueError(
                f"timing.control_period_s = {self.timing.control_period_s} s: expected <= 1 s"
            )
        if isinstance(self.wind, RampWindSpec) and self.wind.end_s < self.wind.start_s:
            raise ValueError("wind.end_s must be >= wind.start_s")

    @property
    def steps_per_cycle(self) -> int:
        """Plant integration steps per control period."""
        return round(self.timing.control_period_s / self.timing.plant_step_s)

    @property
    def cycles(self) -> int:
        """Control cycles in the run."""
        return round(self.duration_s / self.timing.control_period_s)

    def with_duration(self, duration_s: float | None) -> Scenario:
        """A copy with another run length (None keeps this one)."""
        if duration_s is None:
            return self
        return msgspec.structs.replace(self, duration_s=duration_s)

    def to_toml_dict(self) -> dict[str, object]:
        """Plain dict of the scenario (JSON-able), tags included."""
        return msgspec.to_builtins(self)


_UNIT_SUFFIX = re.compile(r"_(s|ms|us|ns|m_s|km_h|rad|deg|rad_s|rpm|nm|n|w|kw|mw|m|hz)$")


def _hint_for_unknown(key: str, known: list[str]) -> str:
    stem = _UNIT_SUFFIX.sub("", key)
    same_stem = [k for k in known if _UNIT_SUFFIX.sub("", k) == stem]
    if same_stem:
        return f"; did you mean {same_stem[0]!r} (units are part of the key name)?"
    close = difflib.get_close_matches(key, known, n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def _known_fields(path: str) -> list[str]:
    """Known keys at a msgspec error path like ``$.timing``."""
    parts = [p for p in path.lstrip("$").split(".") if p]
    cls: type[msgspec.Struct] = Scenario
    sections: dict[str, type[msgspec.Struct]] = {
        "timing": TimingSection,
        "sensors": SensorSection,
        "controller": ControllerSection,
    }
    if parts:
        if parts[0] == "wind":
            return sorted(
                {
                    f
                    for c in (SteadyWindSpec, StepWindSpec, RampWindSpec)
                    for f in c.__struct_fields__
                }
                | {"kind"}
            )
        cls = sections.get(parts[0], Scenario)
    return list(cls.__struct_fields__)


def parse_scenario(text: str, source: str = "<string>") -> Scenario:
    """Parse and validate scenario TOML text.

    Raises
    ------
    ScenarioError
        naming the file and the key at fault.
    """
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from exc
    try:
        return msgspec.convert(raw, Scenario)
    except msgspec.ValidationError as exc:
        msg = str(exc)
        m = re.match(r"Object contains unknown field `([^`]+)`(?: - at `([^`]*)`)?", msg)
        if m:
            key, path = m.group(1), m.group(2) or "$"
            where = path.lstrip("$").lstrip(".")
            full = f"{where}.{key}" if where else key
            hint = _hint_for_unknown(key, _known_fields(path))
            raise ScenarioError(f"{source}: unknown key {full!r}{hint}") from exc
        at = re.search(r" - at `\$\.?([^`]*)`", msg)
        if at:
            msg = f"key {at.group(1)!r}: {msg[: at.start()]}"
        raise ScenarioError(f"{source}: {msg}") from exc


def shipped_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package."""
    root = importlib.resources.files("hil") / "scenarios"
    return sorted(p.name.removesuffix(".toml") for p in root.iterdir() if p.name.endswith(".toml"))


def scenario_text(name_or_path: str) -> tuple[str, str]:
    """The TOML text and its source for a shipped name or a file path."""
    path = Path(name_or_path)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise ScenarioError(f"scenario file {path} does not exist")
        return path.read_text(), str(path)
    res = importlib.resources.files("hil") / "scenarios" / f"{name_or_path}.toml"
    if not res.is_file():
        raise ScenarioError(
            f"no scenario {name_or_path!r}: expected a .toml path or one of {shipped_scenarios()}"
        )
    return res.read_text(), f"hil/scenarios/{name_or_path}.toml"


def load_scenario(name_or_path: str = "default") -> Scenario:
    """Load a shipped scenario by name or a scenario file by path."""
    text, source = scenario_text(name_or_path)
    return parse_scenario(text, source)
