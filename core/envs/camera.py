"""The top-mounted camera and its two domains: the simulator's and a stand-in for the physical camera.

Section 4.2 of the paper transfers policies to a real NICO whose external camera is "slightly differently
aligned" and sees slightly different colours. `CameraShift` describes such a shift (camera pose offset,
colour and lighting change, sensor noise, blur) so that paired sim/real images of the same configuration can
be rendered; users define their own shift by constructing the dataclass (or loading it from YAML/JSON).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

OBS_HEIGHT, OBS_WIDTH = 32, 64
"""The paper's 64×32 RGB observation: 64 pixels wide, 32 high."""


@dataclass(frozen=True)
class CameraPose:
    """A pinhole camera looking at `target` from `eye`; `up` fixes the image's vertical direction."""

    eye: tuple[float, float, float] = (0.05, -0.20, 0.62)
    target: tuple[float, float, float] = (0.26, -0.20, 0.0)
    up: tuple[float, float, float] = (1.0, 0.0, 0.0)
    fov_deg: float = 34.0
    """Vertical field of view; the horizontal one follows from the 2:1 aspect."""
    near: float = 0.05
    far: float = 2.0


@dataclass(frozen=True)
class Lighting:
    """Tiny-renderer light parameters."""

    direction: tuple[float, float, float] = (0.3, 0.2, 1.0)
    ambient: float = 0.6
    diffuse: float = 0.45
    specular: float = 0.05


@dataclass(frozen=True)
class CameraShift:
    """How the real-camera stand-in differs from the simulator's camera (defaults: a few degrees and cm).

    Every field is a deterministic offset except `noise_std`, which is drawn per image from a generator
    seeded by `seed` (and the env's reset seed), so a given shift and seed reproduce the same images.
    """

    yaw_deg: float = 3.0
    """Rotation of the viewing direction about the world z axis."""
    pitch_deg: float = -2.0
    """Tilt of the viewing direction toward (negative) or away from the robot."""
    offset_m: tuple[float, float, float] = (0.015, -0.02, 0.02)
    """Translation of the camera (eye and target together)."""
    fov_delta_deg: float = 1.5
    colour_gain: tuple[float, float, float] = (1.08, 0.96, 0.88)
    """Per-channel multiplicative gain (white balance)."""
    brightness: float = 8.0
    """Additive offset in 0-255 units."""
    contrast: float = 0.9
    """Contrast around mid-grey 128."""
    lighting: Lighting = field(default_factory=lambda: Lighting((-0.4, 0.5, 1.0), 0.5, 0.55, 0.1))
    noise_std: float = 4.0
    """Gaussian sensor noise, 0-255 units."""
    blur_sigma: float = 0.6
    """Gaussian blur in pixels (0 disables)."""
    seed: int = 0

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> CameraShift:
        data = dict(data)
        unknown = set(data) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown camera-shift field(s): {', '.join(sorted(unknown))}")
        if "lighting" in data and isinstance(data["lighting"], dict):
            data["lighting"] = Lighting(**data["lighting"])
        for key in ("offset_m", "colour_gain"):
            if key in data:
                data[key] = tuple(float(v) for v in data[key])
        return cls(**data)


def shifted_pose(pose: CameraPose, shift: CameraShift) -> CameraPose:
    """Apply the pose part of a shift: translate, then rotate the view direction by yaw and pitch."""
    eye = np.asarray(pose.eye) + np.asarray(shift.offset_m)
    view = np.asarray(pose.target) - np.asarray(pose.eye)
    yaw = math.radians(shift.yaw_deg)
    rot_z = np.array([[math.cos(yaw), -math.sin(yaw), 0], [math.sin(yaw), math.cos(yaw), 0], [0, 0, 1]])
    view = rot_z @ view
    up = rot_z @ np.asarray(pose.up)
    # Pitch: rotate the view direction about the camera's horizontal axis.
    side = np.cross(view, up)
    side /= np.linalg.norm(side)
    view = _rotate(view, side, math.radians(shift.pitch_deg))
    up = _rotate(up, side, math.radians(shift.pitch_deg))
    return CameraPose(
        eye=tuple(eye.tolist()),
        target=tuple((eye + view).tolist()),
        up=tuple(up.tolist()),
        fov_deg=pose.fov_deg + shift.fov_delta_deg,
        near=pose.near,
        far=pose.far,
    )


def _rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation of `v` about unit `axis`."""
    return (
        v * math.cos(angle)
        + np.cross(axis, v) * math.sin(angle)
        + axis * np.dot(axis, v) * (1 - math.cos(angle))
    )


def gaussian_blur(image: np.ndarray, sigma: float) -> np.ndarray:
    """Separable Gaussian blur of an HxWxC float image (edge-padded), vectorised over pixels."""
    if sigma <= 0:
        return image
    radius = max(1, math.ceil(2 * sigma))
    taps = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    taps /= taps.sum()
    h, w = image.shape[:2]
    padded = np.pad(image, ((radius, radius), (0, 0), (0, 0)), mode="edge")
    image = sum(t * padded[k : k + h] for k, t in enumerate(taps))
    padded = np.pad(image, ((0, 0), (radius, radius), (0, 0)), mode="edge")
    return sum(t * padded[:, k : k + w] for k, t in enumerate(taps))


def apply_sensor_model(image: np.ndarray, shift: CameraShift, rng: np.random.Generator) -> np.ndarray:
    """Colour, contrast, blur and noise of the real-camera stand-in, on a uint8 HxWx3 image."""
    out = image.astype(np.float32)
    out = out * np.asarray(shift.colour_gain, dtype=np.float32)
    out = (out - 128.0) * shift.contrast + 128.0 + shift.brightness
    out = gaussian_blur(out, shift.blur_sigma)
    if shift.noise_std > 0:
        out = out + rng.normal(0.0, shift.noise_std, size=out.shape).astype(np.float32)
    return np.clip(np.rint(out), 0, 255).astype(np.uint8)
