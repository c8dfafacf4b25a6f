"""The paper's evaluation protocol (Section VI-B), behind ``groundsym evaluate``: one module per job.

- :mod:`.config`: the options that decide the numbers, their fingerprint and their checks;
- :mod:`.protocol`: seeds, one unit (symbols, models, episodes) and the whole evaluation;
- :mod:`.truth`: the simulator's ground-truth relations as an abstraction (a diagnosis oracle);
- :mod:`.store`: the results folder that an interrupted evaluation resumes from;
- :mod:`.results`: the mean over runs, its standard error and the grounding summary (results.json);
- :mod:`.tables`: results.md's tables.

The bar chart (results.png) is drawn by :func:`groundsym.figures.bar_chart`. docs/planning.md
describes the protocol.
"""
