"""The turbine's 3-D scene and frame transforms for the live view, from the presets.

Frames (x downwind, z up, the plant's convention, :mod:`plant.platform`)::

    world      still-water line at the platform's rest position
    platform   the platform reference point (still-water line) moved by surge x, heave z
               and pitched about y (pitch positive when the tower top moves downwind)
    rotor      the hub centre at (0, 0, hub height) in ``platform``, turned about the
               shaft (x) by the rotor azimuth

The truth channel carries surge, heave and pitch (:class:`~bus_schemas.messages.PlantState`
``platform_*``; zero for a bottom-fixed turbine) but no rotor azimuth: the azimuth is the
integral of its ``rotor_speed_rad_s`` over ``sample_time_ns`` (:class:`Azimuth`), which turns
the drawn rotor at the simulated speed, not at a measured angle.

Geometry (:func:`geometry_of`): hub height and rotor radius from the turbine preset, tower
base and top from the floating preset (a bottom-fixed turbine: from the ground to the hub).
A floating preset gives no draft: the hull is drawn as the equivalent cylinder of the
preset's hydrostatics, its waterplane area ``C33 / (rho g)`` from the heave hydrostatic
stiffness and its depth the displaced volume over that area, capped at the water depth
(OC3-Hywind: radius 3.25 m, the spar's waterplane, 242 m deep for its 120 m taper; a preset
without heave stiffness (the TLP): a cylinder as deep as it is wide).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

#: Colours of the drawn parts (RGBA, 0..1).
_HULL = (0.85, 0.45, 0.1, 0.9)
_TOWER = (0.8, 0.8, 0.82, 1.0)
_NACELLE = (0.95, 0.95, 0.95, 1.0)
_BLADE = (0.9, 0.9, 0.95, 1.0)
_WATER = (0.1, 0.35, 0.7, 0.25)


@dataclass(frozen=True)
class TurbineGeometry:
    """What the scene draws [m]; heights above the still-water line (or the ground).

    Parameters
    ----------
    hub_height_m, rotor_radius_m : float
        From the turbine preset.
    tower_base_m, tower_top_m : float
        Tower ends (floating preset; bottom-fixed: 0 and the hub height less 2 m).
    hull_radius_m, hull_draft_m : float
        The hull's equivalent cylinder (module docstring); 0 for a bottom-fixed turbine.
    blade_count : int
        Blades drawn.
    """

    hub_height_m: float
    rotor_radius_m: float
    tower_base_m: float
    tower_top_m: float
    hull_radius_m: float = 0.0
    hull_draft_m: float = 0.0
    blade_count: int = 3

    def __post_init__(self) -> None:
        for name in ("hub_height_m", "rotor_radius_m", "tower_top_m"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name}: expected > 0, got {getattr(self, name)!r}")
        if not self.tower_top_m > self.tower_base_m:
            raise ValueError(
                f"tower_top_m {self.tower_top_m!r}: expected above tower_base_m "
                f"{self.tower_base_m!r}"
            )


def geometry_of(turbine: str, platform: str | None) -> TurbineGeometry:
    """The :class:`TurbineGeometry` of a scenario's turbine and platform presets."""
    from plant.platform import _resolve, read_floating_preset  # noqa: PLC0415
    from plant.turbine import load_turbine  # noqa: PLC0415

    tp = load_turbine(turbine)
    if platform is None:
        return TurbineGeometry(
            hub_height_m=tp.hub_height_m,
            rotor_radius_m=tp.rotor_radius_m,
            tower_base_m=0.0,
            tower_top_m=max(tp.hub_height_m - 2.0, 1.0),
        )
    preset, base, _source = read_floating_preset(platform)
    volume = preset.displaced_volume_m3
    with _resolve(base, preset.hydro_file).open("rb") as fh:
        hydro = np.load(fh)
        dofs = [int(d) for d in hydro["dofs"]]
        c33 = (
            float(hydro["hydrostatic_stiffness"][dofs.index(2), dofs.index(2)])
            if 2 in dofs
            else 0.0
        )
    if c33 > 0.0:
        area = c33 / (preset.water_density_kg_m3 * preset.gravity_m_s2)
        radius = math.sqrt(area / math.pi)
        draft = min(volume / area, preset.water_depth_m)
    else:  # a cylinder as deep as it is wide, of the displaced volume
        radius = (volume / (2.0 * math.pi)) ** (1.0 / 3.0)
        draft = 2.0 * radius
    return TurbineGeometry(
        hub_height_m=tp.hub_height_m,
        rotor_radius_m=tp.rotor_radius_m,
        tower_base_m=preset.tower_base_height_m,
        tower_top_m=preset.tower_top_height_m,
        hull_radius_m=radius,
        hull_draft_m=draft,
        blade_count=preset.blade_count,
    )


class Azimuth:
    """The rotor azimuth [rad] integrated from the truth's rotor speed (module docstring).

    Trapezoidal in simulated time; a message out of order (``sample_time_ns`` not after
    the last) restarts the integration from it without a step.
    """

    def __init__(self) -> None:
        self.angle_rad = 0.0
        self._last: tuple[int, float] | None = None

    def update(self, sample_time_ns: int, rotor_speed_rad_s: float) -> float:
        """Advance to ``sample_time_ns`` [ns] at ``rotor_speed_rad_s``; return the azimuth."""
        if self._last is not None and sample_time_ns > self._last[0]:
            dt = (sample_time_ns - self._last[0]) * 1e-9
            self.angle_rad = (self.angle_rad + 0.5 * (self._last[1] + rotor_speed_rad_s) * dt) % (
                2.0 * math.pi
            )
        self._last = (sample_time_ns, rotor_speed_rad_s)
        return self.angle_rad


def _quat_y(angle_rad: float) -> Any:
    from foxglove.messages import Quaternion  # noqa: PLC0415

    return Quaternion(x=0.0, y=math.sin(angle_rad / 2), z=0.0, w=math.cos(angle_rad / 2))


def _quat_x(angle_rad: float) -> Any:
    from foxglove.messages import Quaternion  # noqa: PLC0415

    return Quaternion(x=math.sin(angle_rad / 2), y=0.0, z=0.0, w=math.cos(angle_rad / 2))


def _stamp(unix_ns: int) -> Any:
    from foxglove.messages import Timestamp  # noqa: PLC0415

    return Timestamp(unix_ns // 1_000_000_000, unix_ns % 1_000_000_000)


def transforms(
    geometry: TurbineGeometry,
    unix_ns: int,
    surge_m: float,
    heave_m: float,
    pitch_rad: float,
    azimuth_rad: float,
) -> Any:
    """The ``world -> platform`` and ``platform -> rotor`` transforms of one sample, one
    ``foxglove.FrameTransforms`` message."""
    from foxglove.messages import FrameTransform, FrameTransforms, Vector3  # noqa: PLC0415

    ts = _stamp(unix_ns)
    return FrameTransforms(
        transforms=[
            FrameTransform(
                timestamp=ts,
                parent_frame_id="world",
                child_frame_id="platform",
                translation=Vector3(x=surge_m, y=0.0, z=heave_m),
                rotation=_quat_y(pitch_rad),
            ),
            FrameTransform(
                timestamp=ts,
                parent_frame_id="platform",
                child_frame_id="rotor",
                translation=Vector3(x=0.0, y=0.0, z=geometry.hub_height_m),
                rotation=_quat_x(azimuth_rad),
            ),
        ]
    )


def scene(geometry: TurbineGeometry, unix_ns: int) -> Any:
    """The ``foxglove.SceneUpdate`` of the turbine: water, hull, tower, nacelle, rotor."""
    from foxglove.messages import (  # noqa: PLC0415
        Color,
        CubePrimitive,
        CylinderPrimitive,
        Pose,
        Quaternion,
        SceneEntity,
        SceneUpdate,
        SpherePrimitive,
        Vector3,
    )

    g = geometry
    ts = _stamp(unix_ns)
    ident = Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)

    def color(c: tuple[float, float, float, float]) -> Any:
        return Color(r=c[0], g=c[1], b=c[2], a=c[3])

    def cylinder(z0: float, z1: float, r0: float, r1: float, c: Any) -> Any:
        r = max(r0, r1)
        return CylinderPrimitive(
            pose=Pose(position=Vector3(x=0.0, y=0.0, z=0.5 * (z0 + z1)), orientation=ident),
            size=Vector3(x=2 * r, y=2 * r, z=z1 - z0),
            bottom_scale=r0 / r,
            top_scale=r1 / r,
            color=color(c),
        )

    tower_r = max(0.03 * g.hub_height_m, 1.0)
    platform_parts: dict[str, Any] = {
        "cylinders": [cylinder(g.tower_base_m, g.tower_top_m, tower_r, 0.6 * tower_r, _TOWER)]
    }
    hull_r = g.hull_radius_m
    if g.hull_draft_m > 0.0:
        platform_parts["cylinders"].append(
            cylinder(-g.hull_draft_m, max(g.tower_base_m, 0.0), hull_r, hull_r, _HULL)
        )
    rr = g.rotor_radius_m
    nacelle = CubePrimitive(
        pose=Pose(position=Vector3(x=2.0, y=0.0, z=g.hub_height_m), orientation=ident),
        size=Vector3(x=0.2 * rr, y=0.06 * rr, z=0.06 * rr),
        color=color(_NACELLE),
    )
    blades = []
    chord = max(0.06 * g.rotor_radius_m, 0.5)
    for k in range(g.blade_count):
        a = 2.0 * math.pi * k / g.blade_count
        mid = 0.5 * g.rotor_radius_m
        blades.append(
            CubePrimitive(
                # in the rotor plane (y-z), pointing outwards at angle a from +z
                pose=Pose(
                    position=Vector3(x=-3.0, y=-mid * math.sin(a), z=mid * math.cos(a)),
                    orientation=_quat_x(a),
                ),
                size=Vector3(x=0.3 * chord, y=chord, z=g.rotor_radius_m),
                color=color(_BLADE),
            )
        )
    hub = SpherePrimitive(
        pose=Pose(position=Vector3(x=-3.0, y=0.0, z=0.0), orientation=ident),
        size=Vector3(x=2.5 * chord, y=2.5 * chord, z=2.5 * chord),
        color=color(_NACELLE),
    )
    water = CubePrimitive(
        pose=Pose(position=Vector3(x=0.0, y=0.0, z=-0.25), orientation=ident),
        size=Vector3(x=6 * g.rotor_radius_m, y=6 * g.rotor_radius_m, z=0.5),
        color=color(_WATER),
    )
    # Frame-locked: each part follows its frame's latest transform, whatever the scene's own
    # timestamp (a lock-step run's log times run ahead of the wall clock).
    return SceneUpdate(
        entities=[
            SceneEntity(
                timestamp=ts, frame_id="world", id="water", frame_locked=True, cubes=[water]
            ),
            SceneEntity(
                timestamp=ts,
                frame_id="platform",
                id="platform",
                frame_locked=True,
                cubes=[nacelle],
                **platform_parts,
            ),
            SceneEntity(
                timestamp=ts,
                frame_id="rotor",
                id="rotor",
                frame_locked=True,
                cubes=blades,
                spheres=[hub],
            ),
        ]
    )
