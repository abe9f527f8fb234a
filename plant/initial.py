"""Where a run starts: :class:`InitialCondition` (frozen, validated; see :mod:`plant.build`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["InitialCondition"]


@dataclass(frozen=True)
class InitialCondition:
    """Where a run starts (None: the plant's own default for that quantity; module docstring).

    Parameters
    ----------
    rotor_speed_rad_s : float, optional
        Rotor (low-speed shaft) speed ω [rad/s], >= 0.
    blade_pitch_rad : float, optional
        Collective blade pitch θ [rad] (actuator position and held demand).
    generator_torque_nm : float, optional
        Generator torque T_g [N m, high-speed shaft] (actuator and held demand); None with a
        rotor point given: the torque that balances the aerodynamic torque there.
    platform_surge_m, platform_heave_m : float, optional
        Platform surge and heave [m]; None: the static equilibrium under the mean thrust.
    platform_pitch_rad : float, optional
        Platform pitch [rad]; None: the static equilibrium.
    wind_m_s : float, optional
        Steady hub-height wind [m/s] the rotor point and the platform equilibrium are solved
        at (a trim's mean wind); None: the run's wind at t = 0.
    """

    rotor_speed_rad_s: float | None = None
    blade_pitch_rad: float | None = None
    generator_torque_nm: float | None = None
    platform_surge_m: float | None = None
    platform_heave_m: float | None = None
    platform_pitch_rad: float | None = None
    wind_m_s: float | None = None

    def __post_init__(self) -> None:
        for name in (
            "rotor_speed_rad_s",
            "blade_pitch_rad",
            "generator_torque_nm",
            "platform_surge_m",
            "platform_heave_m",
            "platform_pitch_rad",
            "wind_m_s",
        ):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, int | float) and math.isfinite(v)):
                raise ValueError(f"InitialCondition.{name}: expected a finite number, got {v!r}")
        if self.rotor_speed_rad_s is not None and self.rotor_speed_rad_s < 0.0:
            raise ValueError(
                "InitialCondition.rotor_speed_rad_s must be >= 0 rad/s, got "
                f"{self.rotor_speed_rad_s}"
            )
        if self.wind_m_s is not None and self.wind_m_s < 0.0:
            raise ValueError(f"InitialCondition.wind_m_s must be >= 0 m/s, got {self.wind_m_s}")
        if self.generator_torque_nm is not None and self.generator_torque_nm < 0.0:
            raise ValueError(
                f"InitialCondition.generator_torque_nm must be >= 0 N m, got "
                f"{self.generator_torque_nm}"
            )

    @property
    def is_default(self) -> bool:
        """True when every field is None (the plant's own default start)."""
        return all(v is None for v in self.__dict__.values())
