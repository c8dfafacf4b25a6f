"""groundsym: learn grounded relational symbols from continuous robot data.

The core package. Simulations live in `sims`, planners in `planners`; both build on this
package and are found by name through :mod:`groundsym.registry`.
"""

__version__ = "0.1.0"
