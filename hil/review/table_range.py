"""How often the rotor left its Cp/Ct/Cq table during a run, from the recorded truth alone.

The plant looks the rotor's coefficients up bilinearly in the turbine's table
(:class:`plant.aero.PerformanceTable`, the compiled :func:`plant._kernels.coefficients_clamped`)
at the tip-speed ratio λ = Ω R / U_rel and the blade pitch θ, and clamps both to the table's
grid: outside it the coefficients are those of the edge, not an extrapolation (the IEA 15 MW
at 4 m/s runs at λ ≈ 15.8 against a table ending at 14.5). A run that did so is not wrong, but
its aerodynamics there are the edge's, and the review says how much.

The truth message (``PlantState``) already carries the two inputs of the look-up,
``tip_speed_ratio`` (the λ the plant used) and ``blade_pitch_rad``, at every recorded cycle, in
process and on the bus alike, so the count needs no new message field: a recorded sample is
*outside* when the aerodynamics were on (``relative_wind_speed_m_s`` above
:data:`plant.turbine.WIND_MIN_M_S`) and λ or θ lay outside the table's range. The table is the
scenario's turbine's (read from the log's scenario); when it cannot be loaded, nothing is
counted and the result says why.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

__all__ = ["RotorTableRange", "table_range_note"]


class RotorTableRange:
    """Accumulates recorded truth samples against the turbine's table range (whole run).

    Parameters
    ----------
    metadata : mapping
        The log's metadata (its ``scenario`` record names the turbine); read at the first
        truth batch, which comes after the metadata.
    """

    def __init__(self, metadata: Mapping[str, Mapping[str, str]]) -> None:
        self._metadata = metadata
        self._range: tuple[float, float, float, float] | None = None
        self._error: str | None = None
        self._resolved = False
        self.samples = 0
        self.outside = 0
        self.tsr_above = 0
        self.tsr_below = 0
        self.pitch_outside = 0
        self.tsr_max = -math.inf
        self.tsr_min = math.inf

    def _resolve(self) -> None:
        self._resolved = True
        import json  # noqa: PLC0415

        try:
            config = json.loads(self._metadata.get("scenario", {}).get("json") or "{}")
            turbine = config.get("turbine")
            if not turbine:
                self._error = "the log's scenario names no turbine"
                return
            from plant.turbine import load_turbine  # noqa: PLC0415

            table = load_turbine(str(turbine)).table
        except (ValueError, OSError) as exc:
            self._error = f"turbine table not loaded: {exc}"
            return
        self._range = (
            float(table.tsr[0]),
            float(table.tsr[-1]),
            float(table.pitch_rad[0]),
            float(table.pitch_rad[-1]),
        )

    def add(self, columns: Mapping[str, np.ndarray]) -> None:
        """One batch of truth columns (``tip_speed_ratio``, ``blade_pitch_rad``,
        ``relative_wind_speed_m_s``)."""
        if not self._resolved:
            self._resolve()
        if self._range is None:
            return
        from plant.turbine import WIND_MIN_M_S  # noqa: PLC0415

        tsr = np.asarray(columns["tip_speed_ratio"], dtype=np.float64)
        pitch = np.asarray(columns["blade_pitch_rad"], dtype=np.float64)
        on = np.asarray(columns["relative_wind_speed_m_s"], dtype=np.float64) > WIND_MIN_M_S
        on &= np.isfinite(tsr) & np.isfinite(pitch)
        lo, hi, p_lo, p_hi = self._range
        tsr, pitch = tsr[on], pitch[on]
        above, below = tsr > hi, tsr < lo
        p_out = (pitch < p_lo) | (pitch > p_hi)
        self.samples += int(tsr.size)
        self.outside += int(np.count_nonzero(above | below | p_out))
        self.tsr_above += int(np.count_nonzero(above))
        self.tsr_below += int(np.count_nonzero(below))
        self.pitch_outside += int(np.count_nonzero(p_out))
        if tsr.size:
            self.tsr_max = max(self.tsr_max, float(tsr.max()))
            self.tsr_min = min(self.tsr_min, float(tsr.min()))

    def result(self) -> dict[str, Any]:
        """``summary["rotor_table"]``: counts, extremes and the table's range.

        ``samples``: recorded truth samples with the aerodynamics on; ``outside``: those with
        λ or θ outside the table (clamped look-up), split into ``tsr_above``, ``tsr_below``
        and ``pitch_outside``; ``tsr_max``/``tsr_min`` reached; ``table_tsr``,
        ``table_pitch_deg``: the table's range; ``error`` when the table was not loaded.
        """
        if self._range is None:
            return {"samples": 0, "outside": None, "error": self._error}
        lo, hi, p_lo, p_hi = self._range
        return {
            "samples": self.samples,
            "outside": self.outside,
            "tsr_above": self.tsr_above,
            "tsr_below": self.tsr_below,
            "pitch_outside": self.pitch_outside,
            "tsr_max": self.tsr_max if self.samples else None,
            "tsr_min": self.tsr_min if self.samples else None,
            "table_tsr": [lo, hi],
            "table_pitch_deg": [round(math.degrees(p_lo), 9), round(math.degrees(p_hi), 9)],
        }


def table_range_note(rotor_table: Mapping[str, Any] | None) -> str | None:
    """The review's note on a run that left its table (None when it did not)."""
    if not rotor_table or not rotor_table.get("outside"):
        return None
    t = rotor_table
    lo, hi = t["table_tsr"]
    p_lo, p_hi = t["table_pitch_deg"]
    share = 100.0 * t["outside"] / max(int(t["samples"]), 1)
    return (
        f"rotor outside its Cp/Ct table in {t['outside']} of {t['samples']} samples "
        f"({share:.1f} %; coefficients clamped to the table's edge): tip-speed ratio "
        f"{t['tsr_min']:.2f}..{t['tsr_max']:.2f} reached, table {lo:g}..{hi:g} "
        f"(above {t['tsr_above']}, below {t['tsr_below']}), pitch outside "
        f"{p_lo:g}..{p_hi:g} deg in {t['pitch_outside']}"
    )
