"""Policies that pick the next primitive (found by name via groundsym.registry)."""
