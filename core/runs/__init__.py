"""One training run: the trainer loop, the run directory and its bookkeeping (checkpoints, metrics.csv,
summary), the metrics (AuC, final performance), the method registry (``--algo`` → agent), loading a trained
policy from a run directory, and the ITM-region diagnostic of a trained encoder.

May import ``core.config``, ``core.envs``, ``core.modelfree`` and ``core.dual``; ``core.experiments`` and
``core.deploy`` build on it.
"""
