"""dualsys registry."""
