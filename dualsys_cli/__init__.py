"""dualsys dualsys_cli."""
