"""One naming of the review's KPIs, with units, for every table that shows them.

``summary.json`` keeps each KPI in SI units under a name that says its unit
(``rotor_speed_mean_rad_s``); a table shows it to a person in the unit a turbine engineer
reads (rpm, MW, kN m) under a label in words. :data:`REVIEW_KPIS` declares both once; the
review's console table (:func:`hil.review.core.render_summary`), ``fowt compare`` (its
console table, ``compare.html`` and the ``kpi_names`` of ``compare.json``) and ``fowt
report`` (:mod:`hil.campaign.html_report`) take their rows from it, so a KPI has one name and
one unit wherever it is shown.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from hil.review import kpi

__all__ = ["REVIEW_KPIS", "KpiName", "heading", "kpi_name", "shown"]

RPM_PER_RAD_S = 30.0 / math.pi


@dataclass(frozen=True)
class KpiName:
    """How one KPI of ``summary["kpi"]`` is shown.

    Parameters
    ----------
    key : str
        Its name in ``summary["kpi"]`` (SI unit in the name).
    label : str
        Words for a table's row.
    unit : str
        The unit it is shown in.
    scale : float
        Shown value = stored value x scale (e.g. 30/π from rad/s to rpm).
    console : bool
        A row of ``fowt review``'s KPI table (False: a parameter of other KPIs, shown in the
        reports only).
    """

    key: str
    label: str
    unit: str
    scale: float = 1.0
    console: bool = True

    @property
    def heading(self) -> str:
        """``label [unit]``."""
        return f"{self.label} [{self.unit}]"

    def shown(self, value: Any) -> Any:
        """The stored value in :attr:`unit` (anything not a number as it is: None, '-')."""
        if isinstance(value, bool) or not isinstance(value, int | float):
            return value
        return float(value) * self.scale


_M = f"{kpi.DEL_WOHLER_M:g}"

#: The review's KPIs in the order the tables show them.
REVIEW_KPIS: tuple[KpiName, ...] = (
    KpiName("mean_power_w", "mean electrical power", "MW", 1e-6),
    KpiName("rotor_speed_mean_rad_s", "rotor speed mean", "rpm", RPM_PER_RAD_S),
    KpiName("rotor_speed_std_rad_s", "rotor speed std", "rpm", RPM_PER_RAD_S),
    KpiName("pitch_travel_deg_s", "pitch travel |dθ/dt|", "deg/s"),
    KpiName("generator_torque_mean_nm", "generator torque mean", "kN m", 1e-3),
    KpiName("thrust_mean_n", "thrust mean", "kN", 1e-3),
    KpiName("thrust_max_n", "thrust max", "kN", 1e-3),
    KpiName("shaft_del_nm", f"shaft DEL (m={_M})", "kN m", 1e-3),
    KpiName("thrust_del_n", f"thrust DEL (m={_M})", "kN", 1e-3),
    KpiName("tower_base_moment_mean_nm", "tower-base moment mean", "MN m", 1e-6),
    KpiName("tower_base_del_nm", f"tower-base DEL (m={_M})", "MN m", 1e-6),
    KpiName("platform_pitch_mean_deg", "platform pitch mean", "deg"),
    KpiName("platform_pitch_std_deg", "platform pitch std", "deg"),
    KpiName("surge_mean_m", "surge mean", "m"),
    KpiName("surge_std_m", "surge std", "m"),
    KpiName("shaft_del_wohler_m", "shaft DEL Wöhler exponent", "1", console=False),
    KpiName("del_n_eq_hz", "DEL equivalent frequency", "Hz", console=False),
)

_BY_KEY = {k.key: k for k in REVIEW_KPIS}


def kpi_name(key: str) -> KpiName:
    """The :class:`KpiName` of ``summary["kpi"][key]``; a key not declared here is shown as
    it is (its SI unit in its name, scale 1)."""
    return _BY_KEY.get(key) or KpiName(key, key.replace("_", " "), "as named")


def heading(key: str) -> str:
    """``label [unit]`` of ``summary["kpi"][key]``."""
    return kpi_name(key).heading


def shown(key: str, value: Any) -> Any:
    """``summary["kpi"][key]``'s value in its shown unit."""
    return kpi_name(key).shown(value)
