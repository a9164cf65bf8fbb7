"""Procedural description of the NICO-like scene: robot, table and glass as URDF text.

pybullet_data ships no NICO, so the robot is generated here from a few dimensions (`ArmGeometry`). The
geometry follows Section 4.1.1 of the paper: a child-size humanoid (about 1 m tall when standing) seated at a
table; its right arm has one shoulder joint with a ±100° range that sweeps the forearm and hand over the
table top; the hand has one thumb and two index fingers with three joints each (Fig. 7a), all driven by one
tendon command.

Frames. World: x forward (away from the robot, across the table), y to the robot's left, z up; the table
top is at z = 0. The shoulder joint turns about a vertical axis through `shoulder_xy` (the upper arm
hangs along it; the elbow is bent 90° so the forearm lies over the table). At joint angle q the forearm
points along d(q) = (sin q, −cos q): q = 0 points to the robot's right, q = 90° straight ahead. In the
arm link's frame, x is radial (along the forearm), y is the tangent in the direction of increasing q, z
is up. The palm is a plate facing +y; the index fingers stand on its outer edge and the thumb on its
inner edge, all pointing +y when open, so the open hand is a U that a glass enters when the shoulder
angle increases.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class ArmGeometry:
    """Dimensions of the generated robot and scene, in metres and kilograms."""

    shoulder_xy: tuple[float, float] = (0.0, -0.12)
    """World position of the vertical shoulder axis."""
    shoulder_height: float = 0.30
    """Height of the shoulder joint above the table top."""
    hand_height: float = 0.09
    """Height of the hand (palm centre, finger plane) above the table top."""
    reach: float = 0.30
    """Radial distance from the shoulder axis to the palm centre."""
    grasp_offset: float = 0.04
    """Distance of the hand centre (the grasp point) in front of the palm surface."""
    palm_width: float = 0.11
    palm_height: float = 0.07
    palm_thickness: float = 0.01
    finger_link_length: float = 0.03
    finger_width: float = 0.012
    finger_height: float = 0.014
    finger_spread: float = 0.05
    """Radial offset of the finger bases from the palm centre (index outside, thumb inside)."""
    index_z_offset: float = 0.02
    """The two index fingers sit this far above and below the thumb."""
    glass_radius: float = 0.025
    glass_height: float = 0.18
    glass_mass: float = 0.15
    table_size: tuple[float, float] = (0.60, 0.90)
    table_center_xy: tuple[float, float] = (0.33, -0.15)

    @property
    def hand_centre_radius(self) -> float:
        """Distance from the shoulder axis to the hand centre."""
        return math.hypot(self.reach, self.grasp_offset)

    @property
    def hand_centre_lead(self) -> float:
        """Angle (rad) by which the hand centre leads the forearm direction."""
        return math.atan2(self.grasp_offset, self.reach)


NICO_WHITE = "0.92 0.92 0.90 1"
NICO_SKIN = "0.95 0.78 0.65 1"
NICO_JOINT = "0.25 0.25 0.28 1"


def _material_name(rgba: str) -> str:
    return "c_" + rgba.replace(" ", "_").replace(".", "")


def _visual(origin: str, geom: str, rgba: str) -> str:
    material = f'<material name="{_material_name(rgba)}"><color rgba="{rgba}"/></material>'
    return f"<visual>{origin}{geom}{material}</visual>"


def _box(size: tuple[float, float, float], xyz: tuple[float, float, float], rgba: str, collide: bool) -> str:
    geom = f'<geometry><box size="{size[0]:.4f} {size[1]:.4f} {size[2]:.4f}"/></geometry>'
    origin = f'<origin xyz="{xyz[0]:.4f} {xyz[1]:.4f} {xyz[2]:.4f}"/>'
    visual = _visual(origin, geom, rgba)
    collision = f"<collision>{origin}{geom}</collision>" if collide else ""
    return visual + collision


def _cylinder(radius: float, length: float, xyz, rpy, rgba: str, collide: bool) -> str:
    geom = f'<geometry><cylinder radius="{radius:.4f}" length="{length:.4f}"/></geometry>'
    origin = (
        f'<origin xyz="{xyz[0]:.4f} {xyz[1]:.4f} {xyz[2]:.4f}" rpy="{rpy[0]:.4f} {rpy[1]:.4f} {rpy[2]:.4f}"/>'
    )
    visual = _visual(origin, geom, rgba)
    collision = f"<collision>{origin}{geom}</collision>" if collide else ""
    return visual + collision


def _sphere(radius: float, xyz, rgba: str) -> str:
    geom = f'<geometry><sphere radius="{radius:.4f}"/></geometry>'
    origin = f'<origin xyz="{xyz[0]:.4f} {xyz[1]:.4f} {xyz[2]:.4f}"/>'
    return _visual(origin, geom, rgba)


def _inertial(mass: float, diag: float = 1e-4) -> str:
    return (
        f'<inertial><mass value="{mass:.4f}"/>'
        f'<inertia ixx="{diag}" ixy="0" ixz="0" iyy="{diag}" iyz="0" izz="{diag}"/></inertial>'
    )


FINGER_RANGE = math.radians(160)
"""Finger joints move ±160° (Section 4.1.1)."""

FINGER_NAMES = ("thumb", "index_upper", "index_lower")
"""The three tendon-coupled fingers; each has joints `<name>_1`, `<name>_2`, `<name>_3`."""


def robot_urdf(geometry: ArmGeometry = ArmGeometry()) -> str:
    """URDF of the seated robot: fixed torso, head and left arm; right arm with shoulder and 9 finger joints.

    Only the moving right arm and hand collide; the torso, head and left arm are visual only, so that
    nothing but the hand and forearm can touch the glass.
    """
    g = geometry
    sx, sy = g.shoulder_xy
    drop = g.shoulder_height - g.hand_height  # upper-arm length along the vertical axis
    r, half_p = g.reach, g.palm_thickness / 2
    parts: list[str] = ['<?xml version="1.0"?>', '<robot name="nico_like">']
    # Fixed base: torso, head, neck, left arm (visual only). Base frame = world frame at table height.
    parts.append('<link name="torso">')
    parts.append(_inertial(0.0))
    parts.append(_box((0.14, 0.24, 0.36), (sx - 0.12, 0.0, 0.16), NICO_WHITE, collide=False))
    parts.append(_cylinder(0.025, 0.06, (sx - 0.12, 0.0, 0.37), (0, 0, 0), NICO_JOINT, collide=False))
    parts.append(_sphere(0.075, (sx - 0.12, 0.0, 0.46), NICO_WHITE))
    parts.append(_box((0.06, 0.06, 0.28), (sx - 0.06, -sy, 0.17), NICO_WHITE, collide=False))
    parts.append(
        _box((0.06, 0.06, 0.06), (sx - 0.09, sy + 0.005, g.shoulder_height), NICO_JOINT, collide=False)
    )
    parts.append("</link>")
    # Right arm: one link carrying upper arm, forearm and palm; joint axis vertical through the shoulder.
    parts.append('<link name="right_arm">')
    parts.append(_inertial(0.8, 2e-3))
    parts.append(_cylinder(0.022, drop, (0, 0, -drop / 2), (0, 0, 0), NICO_WHITE, collide=False))
    forearm_len = r - g.palm_width / 2 - 0.02
    parts.append(
        _cylinder(
            0.018, forearm_len, (0.02 + forearm_len / 2, -0.025, -drop), (0, math.pi / 2, 0), NICO_WHITE, True
        )
    )
    parts.append(_box((g.palm_width, g.palm_thickness, g.palm_height), (r, -half_p, -drop), NICO_SKIN, True))
    parts.append("</link>")
    parts.append(
        '<joint name="shoulder" type="revolute"><parent link="torso"/><child link="right_arm"/>'
        f'<origin xyz="{sx:.4f} {sy:.4f} {g.shoulder_height:.4f}" rpy="0 0 {-math.pi / 2:.6f}"/>'
        '<axis xyz="0 0 1"/>'
        f'<limit lower="{-math.radians(100):.6f}" upper="{math.radians(100):.6f}" effort="60" velocity="5"/>'
        "</joint>"
    )
    bases = {
        "thumb": (r - g.finger_spread, 0.0, -1.0),
        "index_upper": (r + g.finger_spread, g.index_z_offset, 1.0),
        "index_lower": (r + g.finger_spread, -g.index_z_offset, 1.0),
    }
    length = g.finger_link_length
    for name in FINGER_NAMES:
        bx, bz, axis_sign = bases[name]
        parent = "right_arm"
        for k in (1, 2, 3):
            link = f"{name}_link_{k}"
            parts.append(f'<link name="{link}">')
            parts.append(_inertial(0.01, 1e-6))
            parts.append(
                _box((g.finger_width, length, g.finger_height), (0, length / 2, 0), NICO_SKIN, collide=True)
            )
            parts.append("</link>")
            origin = (bx, 0.0, -drop + bz) if k == 1 else (0.0, length, 0.0)
            parts.append(
                f'<joint name="{name}_{k}" type="revolute"><parent link="{parent}"/><child link="{link}"/>'
                f'<origin xyz="{origin[0]:.4f} {origin[1]:.4f} {origin[2]:.4f}"/>'
                f'<axis xyz="0 0 {axis_sign:.0f}"/>'
                f'<limit lower="{-FINGER_RANGE:.6f}" upper="{FINGER_RANGE:.6f}" effort="2" velocity="8"/>'
                "</joint>"
            )
            parent = link
    parts.append("</robot>")
    return "\n".join(parts)


def table_urdf(geometry: ArmGeometry = ArmGeometry()) -> str:
    """A fixed table whose top surface is the plane z = 0 over `table_size`, with four legs (visual)."""
    sx, sy = geometry.table_size
    cx, cy = geometry.table_center_xy
    parts = ['<?xml version="1.0"?>', '<robot name="table">', '<link name="top">', _inertial(0.0)]
    parts.append(_box((sx, sy, 0.03), (cx, cy, -0.015), "0.80 0.66 0.47 1", collide=True))
    for lx in (cx - sx / 2 + 0.03, cx + sx / 2 - 0.03):
        for ly in (cy - sy / 2 + 0.03, cy + sy / 2 - 0.03):
            parts.append(_box((0.04, 0.04, 0.6), (lx, ly, -0.33), "0.55 0.42 0.30 1", collide=False))
    parts.append(_box((3.0, 3.0, 0.01), (0.3, 0.0, -0.64), "0.55 0.57 0.60 1", collide=False))
    parts += ["</link>", "</robot>"]
    return "\n".join(parts)


def glass_urdf(geometry: ArmGeometry = ArmGeometry()) -> str:
    """The grasp target: an upright cylinder whose base frame is its centre of mass."""
    g = geometry
    return "\n".join(
        [
            '<?xml version="1.0"?>',
            '<robot name="glass">',
            '<link name="glass">',
            _inertial(g.glass_mass, g.glass_mass * (3 * g.glass_radius**2 + g.glass_height**2) / 12),
            _cylinder(g.glass_radius, g.glass_height, (0, 0, 0), (0, 0, 0), "0.15 0.45 0.85 1", collide=True),
            "</link>",
            "</robot>",
        ]
    )
