"""Upper bounds of every count and size a command takes, checked before any work.

Why: an absurd value (a typo, a pasted number, a hostile input) used to run for minutes before it
failed or ran for ever (``plan --steps 10**9``), or ended in a traceback (``collect --traces
99999999999999999999999``: ``OverflowError`` from numpy's ``SeedSequence.spawn``). Each bound is
far beyond real use and named in the one-line refusal; docs/reliability.md's limits table lists
them and why each is where it is. A new count option gets its bound here (the test that walks
every option of the parsers fails for one without).
"""

from __future__ import annotations

# 100 times the paper's budget of 1e5 loss evaluations; 1e9 would run for weeks
MAX_EVALS = 10_000_000
MAX_RESTARTS = 1_000            # restarts share the budget: 1,000 leave 10,000 evaluations each at most
MAX_WORKERS = 1_024             # processes on this machine; more than any machine has cores
MAX_SYMBOLS = 64                # per arity: far beyond the paper's 1 to 3; memory grows with them
MAX_POPULATION = 64             # candidates per restart, each at ladder**k x the temperature
MAX_HOP_STEPS = 100_000         # a basin hop's settling steps: a hop longer than a whole restart is pointless
MAX_STEPS = 10_000              # primitives per episode: the sims' episodes are 10 to 50 primitives long
MAX_EPISODES = 10_000           # episodes of plan; each is a planner run per step
MAX_TRACES = 100_000            # traces of collect and simulate: the data's JSON grows with traces x length
MAX_LENGTH = 10_000             # primitives per trace
MAX_RUNS = 1_000                # evaluate: independent runs (the paper: 30)
MAX_STARTS = 1_000              # evaluate: start states per run (default 3)
MAX_TRANSITIONS = 1_000_000     # evaluate --symbol-data: transitions per symbol-learning set (the paper: 80 to 640)
MAX_SEED = 2**32 - 1            # seeds: four billion differ enough; a longer number is a pasted one
MAX_PIXELS = 4096               # render's width and height: the software renderer's time and memory grow with the area
