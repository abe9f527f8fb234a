"""Sensor channels of the Hexicon H3 platform: what the heading controller sees.

Every control period the plant samples, through the channel models of
:mod:`sensors.channel` (white Gaussian noise σ, bias, resolution, saturation; seeded per
channel name and run seed), the per-turbine rotor speed, blade pitch, electrical power and
nacelle (waked) wind speed, and the platform's heading, yaw rate and met-mast wind speed and
direction. The channels and their figures are data: the ``[sensors]`` table of the platform
preset (``plant/hexicon/hexicon_h3.toml``); a channel the preset does not name is a perfect
sensor. Per-turbine channels are named ``t<i>_<channel>`` (i = 1, 2, 3) so each has its own
random stream. The truth stays in the plant (and on the recorder's truth keys); the
controllers get only :class:`HexiconSample.measured`.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from sensors.channel import ChannelSpec, SensorSuite

__all__ = [
    "PLATFORM_CHANNELS",
    "TURBINE_CHANNELS",
    "HexiconSensors",
    "load_sensor_table",
]

#: Per-turbine channels (unit): rotor_speed (rad/s), pitch (rad), power (W), nacelle_wind (m/s).
TURBINE_CHANNELS = ("rotor_speed", "pitch", "power", "nacelle_wind")
#: Platform channels (unit): heading (rad), yaw_rate (rad/s), wind_direction (rad),
#: wind_speed (m/s), the last two from the met mast.
PLATFORM_CHANNELS = ("heading", "yaw_rate", "wind_direction", "wind_speed")


def load_sensor_table(name_or_path: str | Path = "hexicon_h3") -> dict[str, Any]:
    """The ``[sensors]`` table of a platform preset (``{}`` when it has none).

    Keys: ``seed`` (int) and one sub-table per channel of :data:`TURBINE_CHANNELS` /
    :data:`PLATFORM_CHANNELS` with :class:`sensors.channel.ChannelSpec` fields.
    """
    text = str(name_or_path)
    if text in ("hexicon_h3", "hexicon-h3"):
        data = (resources.files("plant.hexicon") / "hexicon_h3.toml").read_bytes()
    else:
        data = Path(text).read_bytes()
    table = tomllib.loads(data.decode("utf-8")).get("sensors", {})
    if not isinstance(table, dict):
        raise ValueError(f"{text}: [sensors] expected a table of channels")
    return table


@dataclass(frozen=True)
class HexiconSample:
    """One period's truth and measurement.

    ``measured``/``truth``: ``platform`` dict of :data:`PLATFORM_CHANNELS` and ``turbines``,
    three dicts of :data:`TURBINE_CHANNELS` (SI units, rad).
    """

    platform: dict[str, float]
    turbines: tuple[dict[str, float], dict[str, float], dict[str, float]]


class HexiconSensors:
    """The platform's sensor suite (module docstring).

    Parameters
    ----------
    table : dict
        The preset's ``[sensors]`` table (:func:`load_sensor_table`); ``enabled = false`` or
        an empty table gives perfect sensors.
    seed : int or None
        Run seed; None takes the table's ``seed`` (default 0).

    Raises
    ------
    ValueError
        On an unknown channel or channel key (named, with the allowed ones).
    """

    def __init__(self, table: dict[str, Any], seed: int | None = None) -> None:
        known = {*TURBINE_CHANNELS, *PLATFORM_CHANNELS}
        channels = {k: v for k, v in table.items() if k not in ("seed", "enabled")}
        unknown = sorted(set(channels) - known)
        if unknown:
            raise ValueError(
                f"[sensors]: unknown channel(s) {unknown}; expected {sorted(known)}, seed, enabled"
            )
        self.enabled = bool(table.get("enabled", True)) and bool(channels)
        self.seed = int(table.get("seed", 0)) if seed is None else int(seed)
        specs: dict[str, ChannelSpec] = {}
        for ch in PLATFORM_CHANNELS:
            specs[ch] = ChannelSpec.from_table(ch, channels.get(ch, {}))
        for i in (1, 2, 3):
            for ch in TURBINE_CHANNELS:
                specs[f"t{i}_{ch}"] = ChannelSpec.from_table(f"t{i}_{ch}", channels.get(ch, {}))
        self.suite = SensorSuite(specs, self.seed)

    def measure(self, t_ns: int, truth: HexiconSample) -> HexiconSample:
        """Measured values of every channel at ``t_ns`` (increasing from call to call).

        A lost sample (dropout) holds the channel's last valid value (the controller sees
        no ``nan``).
        """
        if not self.enabled:
            return truth
        flat = dict(truth.platform)
        for i, tur in enumerate(truth.turbines, start=1):
            flat.update({f"t{i}_{k}": v for k, v in tur.items()})
        out = self.suite.step(t_ns, flat)
        last = getattr(self, "_last", {})
        vals = {}
        for k, (y, ok) in out.items():
            vals[k] = y if ok else last.get(k, flat[k])
        self._last = vals
        plat = {k: vals[k] for k in PLATFORM_CHANNELS}
        turs = tuple({k: vals[f"t{i}_{k}"] for k in TURBINE_CHANNELS} for i in (1, 2, 3))
        return HexiconSample(plat, (turs[0], turs[1], turs[2]))
