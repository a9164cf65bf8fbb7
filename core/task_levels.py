"""Task levels of NicoGrasp: named bundles of the env's geometry and rules (docs/environment.md).

A level fixes where the shoulder may move, where it starts, where the glass may stand, which hands it admits
and how many grasp attempts an episode allows. Everything else — the 64×32 top camera, the tendon hand, the
20° action scale, the grasp verification of Section 4.1.2 and the rewards — is the same on every level.

* ``released`` — the authors' released code: the shoulder moves in a 33°–93° window and starts at 33°;
  the glass stands anywhere ahead of the open hand; the hand is automatic or learned as ``hand=`` says. This
  is the task every result before task levels was measured on, observation for observation.
* ``paper`` — Section 4.1 read literally: the policy moves the shoulder over its whole ±100° range and
  closes the hand itself; the shoulder starts at 0° (the real-robot protocol of Section 4.2); the glass
  stands at a new random graspable position each episode, anywhere on the hand's reachable arc at least 20°
  from the start (closer, the 20° verification move back would carry the held glass over the table's edge).
* ``hard`` — ``paper`` plus two rules that make the camera necessary and exploration hard: the glass stands at
  least 30° from the start (one 20° step cannot reach it, so no first-step luck), and an episode allows one
  grasp attempt (a failed verification ends it, with no penalty: sparse stays sparse). A blind policy cannot
  know when to close; a random one closes long before it reaches the glass. Calibrated in docs/environment.md.
* ``seen`` — ``hard`` with the shoulder window starting at the start angle, 0°: the camera sees the arm over
  the whole window (issue 51). On ``hard`` the arm is out of the image from −100° to about −6°, where every
  angle gives the same image; from 0° up every 1° move changes the image of both cameras (sim and real).
  Everything else is ``hard``'s. Calibrated in docs/environment.md ("What the camera sees of the arm").
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass


@dataclass(frozen=True)
class TaskLevel:
    """One task level: the env's geometry and rules that differ between levels."""

    name: str
    summary: str
    shoulder_window_deg: tuple[float, float]
    """Joint limits the policy's moves are clipped to (the NICO shoulder's range is ±100°)."""
    start_deg: float | None
    """Shoulder angle at every reset; None: the low end of the window (released code)."""
    min_glass_offset_deg: float | None
    """Least angle between the start and the glass; None: just ahead of the open fingertips."""
    hand: str
    """The hand mode a level uses when ``hand=`` is not given."""
    hands: tuple[str, ...]
    """Hand modes the level admits."""
    attempts_per_episode: int | None
    """Grasp attempts an episode allows; a failed one past the limit ends the episode. None: unlimited."""
    charge_early_topple: bool = False
    """Dense reward: a topple (−1, ends the episode) is also charged the shaping of the steps it cuts off,
    as a failed attempt that ends the episode is, so that knocking the glass over is never the cheapest
    way out (``hard`` since study 2; docs/environment.md)."""


HARD = TaskLevel(
    name="hard",
    summary="paper, with the glass at least 30° from the start and one grasp attempt per episode",
    shoulder_window_deg=(-100.0, 100.0),
    start_deg=0.0,
    min_glass_offset_deg=30.0,
    hand="learned",
    hands=("learned",),
    attempts_per_episode=1,
    charge_early_topple=True,
)
"""``hard``, named: ``seen`` is this level with another window."""

LEVELS: dict[str, TaskLevel] = {
    level.name: level
    for level in (
        TaskLevel(
            name="released",
            summary="the authors' released code: 33°-93° window, start at 33°, glass ahead of the open hand",
            shoulder_window_deg=(33.0, 93.0),
            start_deg=None,
            min_glass_offset_deg=None,
            hand="auto",
            hands=("auto", "learned"),
            attempts_per_episode=None,
        ),
        TaskLevel(
            name="paper",
            summary="Section 4.1 as written: ±100° shoulder, start at 0°, learned hand, glass anywhere",
            shoulder_window_deg=(-100.0, 100.0),
            start_deg=0.0,
            min_glass_offset_deg=20.0,
            hand="learned",
            hands=("learned", "auto"),
            attempts_per_episode=None,
        ),
        HARD,
        dataclasses.replace(  # everything else as hard: only the window differs
            HARD,
            name="seen",
            summary="hard, with the shoulder window 0°-100°: the camera sees the arm over the whole window",
            shoulder_window_deg=(0.0, 100.0),
        ),
    )
}
"""The levels by name. ``released`` is the default of the env and of the ``default`` profile."""

LEVEL_NAMES = tuple(LEVELS)


def get_level(name: str) -> TaskLevel:
    """The level called `name`; a ValueError listing the levels for any other name."""
    try:
        return LEVELS[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown level {name!r}; choose one of: {', '.join(LEVEL_NAMES)}") from None
