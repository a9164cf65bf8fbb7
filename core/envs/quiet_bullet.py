"""Open a PyBullet client without its C-level chatter on stdout (it prints ``argv[0]=`` on connect).

A `--json` command must print nothing but its JSON line, so the connect call runs with file descriptor 1
pointed at /dev/null for its duration.
"""

from __future__ import annotations

import os
import sys

import pybullet
from pybullet_utils.bullet_client import BulletClient


def quiet_client() -> BulletClient:
    """A DIRECT-mode (headless) PyBullet client; the connect message is discarded."""
    sys.stdout.flush()
    saved = os.dup(1)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        return BulletClient(connection_mode=pybullet.DIRECT)
    finally:
        os.dup2(saved, 1)
        os.close(saved)
        os.close(devnull)
