"""pybullet simulations implementing :class:`groundsym.sim.Sim` (found by name via groundsym.registry)."""
