"""dualsys core/envs."""
