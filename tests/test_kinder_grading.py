"""examples/kinder_table.py's grading of a unary relation about one fixed object (``blocking(X)``:
X stands over *the* target surface) against learned binary symbols with that object as an argument,
on a hand-made recorded dataset whose F1 is counted by hand (docs/kinder.md)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))

from groundsym.recorded import RecordedEpisode, dataset_from_arrays  # noqa: E402
from groundsym.symbols import Symbol, SymbolSet  # noqa: E402
from kinder_table import pair_f1  # noqa: E402

NEAR = Symbol("b1", 2, np.array([0.0]), np.array([0.1]))         # |dx| < 0.083
NEVER = Symbol("b2", 2, np.array([50.0]), np.array([0.1]))


def _dataset():
    # objects blk, tgt, surf along x; blocking(blk) only in scene 0; tgt near the surface in scene 2
    xs = [[1.0, 0.0, 1.05], [0.5, 0.0, 1.05], [0.5, 1.02, 1.05]]
    ep = RecordedEpisode(("blk", "tgt", "surf"), np.array(xs)[:, :, None], ["(move blk)", "(move tgt)"],
                         [0.0, 0.0, 0.0], truth=[["(blocking blk)"], [], []])
    return dataset_from_arrays([ep], ["x"])


def test_pair_f1_counts_a_binary_symbol_with_the_fixed_object_as_the_relation():
    ds = _dataset()
    symbols = SymbolSet.for_dataset([NEAR, NEVER], ds)
    # NEAR(surf, X) (and NEAR(X, surf)) holds for blk in scene 0 (true positive) and tgt in scene 2
    # (false positive): precision 1/2, recall 1, F1 2/3; NEVER scores 0, so the best is NEAR's
    assert pair_f1(symbols, ds, {"blocking": "surf"}) == {"blocking": pytest.approx(2 / 3)}
    assert pair_f1(SymbolSet.for_dataset([NEVER], ds), ds, {"blocking": "surf"}) == {"blocking": 0.0}
    assert pair_f1(symbols, ds, {}) == {}


def test_merge_shards_extends_the_episodes_as_far_as_they_run_without_a_gap(tmp_path):
    from kinder_table import merge_shards
    from groundsym.fileio import atomic_write_json

    head = {"task": "o1", "seed": 0, "arm": "learned", "max_primitives": 0}
    main = tmp_path / "episodes-learned.json"
    atomic_write_json(main, {**head, "episodes": [{"seed": 10}, {"seed": 11}]})
    atomic_write_json(tmp_path / "episodes-learned.shard-0-of-2.json",
                      {**head, "episodes": [{"index": 2, "seed": 12}, {"index": 4, "seed": 14}, {"index": 6, "seed": 16}]})
    atomic_write_json(tmp_path / "episodes-learned.shard-1-of-2.json",
                      {**head, "episodes": [{"index": 3, "seed": 13}]})           # 5 is missing: stop at 4
    merged = merge_shards(main, json.loads(main.read_text())["episodes"], head)
    assert [e["seed"] for e in merged] == [10, 11, 12, 13, 14]
    assert json.loads(main.read_text()) == {**head, "episodes": merged}
