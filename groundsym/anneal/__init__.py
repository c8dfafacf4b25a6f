"""Simulated annealing over a population of candidate symbol sets (paper Section VI).

Each restart anneals a small population of candidate symbol sets. A step picks a candidate and
either perturbs one of its symbols (centre moved by a fraction of its widths, widths scaled in log
space), re-seeds it (a centre drawn from the data, with random or with its old widths), or swaps one whole symbol with
another candidate (the paper's operator that speeds convergence). Moves are accepted by the
Metropolis rule under a geometric temperature schedule, given per transition so it scales with
the data; candidate k of the population runs at ``ladder**k`` times that temperature, and
neighbouring candidates trade states by replica exchange (``ladder=1``: one temperature, no
trades). Late re-seeds can be basin hops that settle the new symbol before they are judged
(``hop_steps``). Restarts are independent (own seed from the run's seed) and run in parallel
worker processes, in rounds of ``chunk`` evaluations; the best over all restarts wins. Everything a
restart needs to continue is a JSON-able state, so a run can be checkpointed after every round
and resumed to the same result, and the result never depends on the number of workers.

At the end, symbols that are never or always true on the training data are pruned and the rest
renamed ``u1, u2, ...`` / ``b1, b2, ...``.
"""

from .checkpoint import CHECKPOINT_SCHEMA, load_checkpoint, save_checkpoint
from .config import LOOKS, AnnealConfig, Candidate, slot_name, slots
from .proposals import IGNORE_WIDTH, ignored_dimensions, perturb, proposal_points, random_symbol, share_radius
from .restart import RestartState, advance, exchange, hops, settle, start_restart, temperature
from .run import AnnealResult, anneal, prune

__all__ = ["CHECKPOINT_SCHEMA", "IGNORE_WIDTH", "LOOKS", "AnnealConfig", "AnnealResult", "Candidate", "RestartState",
           "advance", "anneal", "exchange", "hops", "ignored_dimensions", "load_checkpoint", "perturb",
           "proposal_points", "prune", "random_symbol", "save_checkpoint", "settle", "share_radius", "slot_name",
           "slots", "start_restart", "temperature"]
