"""dualsys service."""
