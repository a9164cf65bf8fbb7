"""A picture of the NicoGrasp scene a person can read: overview beside both domains' 64×32 observations."""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from core.envs.nico_grasp import OVERVIEW_POSE, NicoGraspEnv

PANEL = (512, 256)


def scene_picture(seed: int = 0, hand: str | None = None, level: str = "released") -> Image.Image:
    """Render a freshly reset scene of `level` (its start pose, a seeded glass position): three-quarter view,
    sim observation, real-camera observation (×8)."""
    env = NicoGraspEnv(hand=hand, level=level)
    try:
        env.reset(seed=seed)
        panels = [
            ("scene (three-quarter view)", env.render_view(*PANEL, OVERVIEW_POSE)),
            ("observation, domain=sim (64x32, x8)", _upscale(env.render_observation("sim"))),
            ("observation, domain=real (64x32, x8)", _upscale(env.render_observation("real"))),
        ]
    finally:
        env.close()
    title_h = 22
    canvas = Image.new("RGB", (PANEL[0] * len(panels), PANEL[1] + title_h), "white")
    draw = ImageDraw.Draw(canvas)
    for i, (title, image) in enumerate(panels):
        canvas.paste(Image.fromarray(image), (i * PANEL[0], title_h))
        draw.text((i * PANEL[0] + 8, 4), title, fill="black")
    return canvas


def _upscale(obs: np.ndarray) -> np.ndarray:
    factor = PANEL[1] // obs.shape[0]
    return np.repeat(np.repeat(obs, factor, axis=0), factor, axis=1)
