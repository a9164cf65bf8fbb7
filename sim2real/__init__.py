"""dualsys sim2real."""
