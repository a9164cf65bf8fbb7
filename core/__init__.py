"""The dualsys learning core: environments, networks, agents, world models and the trainer.

`core` imports none of the other dualsys packages (see DESIGN.md, dependency direction).
"""
