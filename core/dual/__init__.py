"""The dual system (Sections 2.2-2.4, Algorithms 1-3): the ITM and its regions, the bank of local world
models, learning progress, the meta-controller's arbitration, gradient MPC, imagination, value expansion,
and the dual-system agents (IM2C, I2A, and the baselines MVE-DDPG, DDPG+CMC, LA-Imagination) with their panel.

May import ``core.config``, ``core.envs`` and ``core.modelfree``; nothing from ``core.runs`` or above.
"""
