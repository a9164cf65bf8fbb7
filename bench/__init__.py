"""dualsys bench."""
