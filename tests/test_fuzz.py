"""Property-based fuzzing (Hypothesis) of every reader a user's file reaches: the PPDDL parser and
the JSON readers of traces, symbolic traces, symbols, rules, reward, the annealing checkpoint and
the evaluation's unit records. Property: every input either loads or raises the project's
UserError, never any other exception, and within a time bound.

Inputs are mutations of valid files (structural edits of the JSON tree or of the PPDDL text, and
edits that keep a file valid, such as reformatting or small numeric changes) plus generated
documents. The default run tries a few hundred; ``-m slow`` runs over 10,000
(``FUZZ_EXAMPLES`` per reader) and checks that at least 30% of the mutants were still valid.
"""

from __future__ import annotations

import json
import os
import signal
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from conftest import DATA
from groundsym.errors import UserError

ROOT = Path(__file__).resolve().parents[1]
FAST, SLOW = 15, int(os.environ.get("FUZZ_EXAMPLES", "1300"))
TIME_LIMIT = 20          # seconds per input: far above any valid file here, so only a hang trips it
OUTCOMES: dict[str, dict[str, int]] = {}


# ----------------------------------------------------------------------------- seed files
def _bw_data(tmp: Path) -> Path:
    from groundsym.ppddl.parser import load
    from groundsym.ppddl.simulate import Task, simulate_traces
    from groundsym.symbolic_traces import write_symbolic_traces

    ref = ROOT / "domains" / "reference" / "blocksworld"
    domain, problem = load(ref / "domain.ppddl", ref / "p01.ppddl")
    ds = simulate_traces(Task(domain, problem), 3, 6, np.random.default_rng(0), 0.2, {})
    write_symbolic_traces(tmp / "bw.json", ds)
    return tmp / "bw.json"


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> dict[str, Path]:
    """One valid file per reader, made by the project's own writers."""
    from groundsym.anneal import AnnealConfig, anneal
    from groundsym.loss import LossConfig, prepare
    from groundsym.modeldir import learn_symbolic_model
    from groundsym.symbolic_traces import read_symbolic_traces
    from groundsym.symbols import SymbolSet, save_symbols
    from groundsym.traces import read_traces
    from tests.test_loss import intended_symbols

    tmp = tmp_path_factory.mktemp("fuzz")
    bw = _bw_data(tmp)
    learn_symbolic_model(read_symbolic_traces(bw), tmp / "model", seed=0, argv=[], progress=False)
    save_symbols(tmp / "symbols.json", SymbolSet(tuple(intended_symbols()), ("x", "y", "z", "size")),
                 shares={"u1": 0.2, "b1": 0.1})
    anneal(prepare(read_traces(DATA / "tower_small.json")), LossConfig(), CHECKPOINT_CFG, 3, workers=1,
           checkpoint=tmp / "checkpoint.json", data_sha256="x")
    _unit_folder(tmp)
    return {"traces": DATA / "tower_small.json", "symbolic": bw, "symbols": tmp / "symbols.json",
            "rules": tmp / "model" / "rules.json", "reward": tmp / "model" / "reward.json",
            "checkpoint": tmp / "checkpoint.json", "unit": tmp / "eval" / "runs" / "N20-run000.json"}


def _eval_config():
    from groundsym.evaluation.config import EvalConfig

    return EvalConfig(sim="tower", methods=("random", "prada"), symbol_data=(20,), model_traces=(1, 3))


def _unit_folder(tmp: Path) -> None:
    from groundsym.evaluation.store import UNIT_SCHEMA, unit_path

    cfg = _eval_config()
    entries = [{"model_traces": n, "method": m, "values": [0.5, 0.25], "mean": 0.375}
               for n in cfg.model_traces for m in cfg.methods]
    report = {"symbols": "learned", "grounding": [
        {"symbol": "u1", "best_match": "inhand", "f1": 0.9, "negation_match": "clear", "negation_f1": 0.4}]}
    path = unit_path(tmp / "eval", 20, 0)
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({"schema": UNIT_SCHEMA, "config": cfg.fingerprint(), "symbol_data": 20, "run": 0,
                                "entries": entries, "report": report, "seconds": 1.0}))


def _checkpoint_cfg():
    from groundsym.anneal import AnnealConfig

    return AnnealConfig(evals=16, restarts=2, chunk=4)


CHECKPOINT_CFG = _checkpoint_cfg()


# ----------------------------------------------------------------------------- readers
def _read_unit(path: Path) -> Any:
    from groundsym.evaluation.results import aggregate

    out = path.parent.parent
    return aggregate(out, _eval_config(), 1, None, None)


def _read_checkpoint(path: Path) -> Any:
    from groundsym.anneal import load_checkpoint
    from groundsym.loss import LossConfig

    return load_checkpoint(path, CHECKPOINT_CFG, LossConfig(), 3, "x")


def _reader(kind: str) -> Callable[[Path], Any]:
    from groundsym.reward import read_reward
    from groundsym.rules.io import read_rules
    from groundsym.symbolic_traces import read_symbolic_traces
    from groundsym.symbols import load_symbols
    from groundsym.traces import read_traces

    return {"traces": read_traces, "symbolic": read_symbolic_traces, "symbols": load_symbols,
            "rules": read_rules, "reward": read_reward, "checkpoint": _read_checkpoint, "unit": _read_unit}[kind]


@contextmanager
def time_bound(seconds: int):
    """A hang fails the test instead of stalling the run."""
    def expire(*_):
        raise TimeoutError(f"no answer within {seconds} s")
    old = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def check(kind: str, read: Callable[[], Any]) -> bool:
    """Loads (True) or raises UserError (False); anything else fails the test."""
    counts = OUTCOMES.setdefault(kind, {"valid": 0, "refused": 0})
    with time_bound(TIME_LIMIT):
        try:
            read()
        except UserError as exc:
            assert "\n" not in str(exc).strip(), f"a multi-line message: {exc}"
            counts["refused"] += 1
            return False
    counts["valid"] += 1
    return True


# ----------------------------------------------------------------------------- JSON mutations
ODD = st.sampled_from([None, True, False, 0, -1, 1, 2, 0.5, -0.0, 1e308, -1e308, 10 ** 30, "", "x", "(on a b)",
                       "?x", [], {}, [[]], [1, 2], {"a": 1}, "🙂", "u1", "(", 3.5e-320])


def _paths(doc: Any, here: tuple = ()) -> list[tuple]:
    out = [here]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*here, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc[:6]):          # the first few items of long lists are enough
            out += _paths(v, (*here, i))
    return out


def _get(doc: Any, path: tuple) -> Any:
    for k in path:
        doc = doc[k]
    return doc


@st.composite
def json_mutant(draw, doc: Any) -> str:
    """A valid document edited 1-3 times; about half of the edits keep it valid."""
    doc = json.loads(json.dumps(doc))
    for _ in range(draw(st.integers(1, 3))):
        paths = _paths(doc)
        path = draw(st.sampled_from(paths))
        op = draw(st.sampled_from(["same", "same", "same", "scale", "replace", "delete", "dup", "wrap", "rename"]))
        node = _get(doc, path)
        parent = _get(doc, path[:-1]) if path else None
        if op == "same":                           # valid edits: order and format only
            continue
        if op == "scale" and isinstance(node, float) and parent is not None:
            parent[path[-1]] = node * draw(st.sampled_from([1.0 + 1e-9, 0.999999, 1.000001]))
        elif op == "replace" and parent is not None:
            parent[path[-1]] = draw(ODD)
        elif op == "delete" and parent is not None:
            del parent[path[-1]]
        elif op == "dup" and isinstance(node, list) and node:
            node.append(json.loads(json.dumps(node[draw(st.integers(0, len(node) - 1))])))
        elif op == "wrap" and parent is not None:
            parent[path[-1]] = [node]
        elif op == "rename" and isinstance(parent, dict):
            parent[path[-1] + "_"] = parent.pop(path[-1])
    text = json.dumps(doc, indent=draw(st.sampled_from([None, 1, 2])))
    cut = draw(st.sampled_from([None] * 9 + ["truncate"]))
    if cut:
        text = text[: draw(st.integers(0, max(0, len(text) - 1)))]
    return text


GENERATED_JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats(allow_nan=True) | st.text(max_size=8),
                              lambda inner: st.lists(inner, max_size=4) | st.dictionaries(
                                  st.sampled_from(["schema", "traces", "steps", "rules", "symbols", "terms",
                                                   "predicates", "restarts", "entries", "x"]), inner, max_size=4),
                              max_leaves=12)

KINDS = ["traces", "symbolic", "symbols", "rules", "reward", "checkpoint", "unit"]


def _json_case(kind: str, seeds: dict[str, Path], tmp: Path, text: str) -> bool:
    path = tmp / seeds[kind].name if kind != "unit" else tmp / "eval" / "runs" / seeds[kind].name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return check(kind, lambda: _reader(kind)(path))


def _json_property(n: int):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    @given(data=st.data())
    def run(kind, seeds, tmp_path_factory, data):
        doc = json.loads(seeds[kind].read_text())
        text = data.draw(st.one_of(json_mutant(doc), json_mutant(doc), json_mutant(doc),
                                   GENERATED_JSON.map(json.dumps)))
        _json_case(kind, seeds, tmp_path_factory.getbasetemp() / f"fz-{kind}", text)
    return run


_fast_json = _json_property(FAST)
_slow_json = _json_property(SLOW)


@pytest.mark.parametrize("kind", KINDS)
def test_json_readers_load_or_refuse_in_one_line(kind, seeds, tmp_path_factory):
    _fast_json(kind, seeds, tmp_path_factory)


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_json_readers_many(kind, seeds, tmp_path_factory):
    _slow_json(kind, seeds, tmp_path_factory)


# ----------------------------------------------------------------------------- PPDDL mutations
PPDDL_FILES = [ROOT / "domains" / "reference" / "blocksworld" / "domain.ppddl",
               ROOT / "domains" / "reference" / "tower" / "domain.ppddl",
               *sorted((DATA / "ippc").glob("*/*/domain.pddl"))]
WORDS = ["(", ")", "(and", "(not", "(probabilistic", "0.5", "1.5", "-1", "?x", "?y", "- block", ":action",
         ":parameters", ":effect", ":precondition", "(forall (?z)", "(when", "(increase (reward) 1)", "(either a b)",
         "(exists (?q)", "(= ?x ?y)", "block", "object", "on", "define", ":types", ":constants", "1/0", "1e999"]


@st.composite
def ppddl_mutant(draw) -> str:
    text = draw(st.sampled_from(PPDDL_FILES)).read_text()
    tokens = text.replace("(", " ( ").replace(")", " ) ").split()
    for _ in range(draw(st.integers(0, 3))):
        i = draw(st.integers(0, len(tokens) - 1))
        op = draw(st.sampled_from(["same", "same", "case", "delete", "insert", "replace", "dup"]))
        if op == "case" and not tokens[i].startswith("?"):
            tokens[i] = tokens[i].lower() if tokens[i].isupper() else tokens[i]
        elif op == "delete":
            del tokens[i]
        elif op == "insert":
            tokens.insert(i, draw(st.sampled_from(WORDS)))
        elif op == "replace":
            tokens[i] = draw(st.sampled_from(WORDS + tokens[:50]))
        elif op == "dup":
            tokens.insert(i, tokens[i])
    sep = draw(st.sampled_from([" ", "\n", " ;; a comment\n"]))
    return sep.join(tokens)


def _ppddl_property(n: int):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    @given(text=st.one_of(ppddl_mutant(), ppddl_mutant(), st.text(alphabet="() ?-:abnotd0.5\n", max_size=200)))
    def run(text):
        from groundsym.ppddl.parser import parse_text

        check("ppddl", lambda: parse_text(text, "<fuzz>"))
    return run


_fast_ppddl = _ppddl_property(3 * FAST)
_slow_ppddl = _ppddl_property(3 * SLOW)


def test_ppddl_parser_parses_or_refuses_in_one_line():
    _fast_ppddl()


@pytest.mark.slow
def test_ppddl_parser_many():
    _slow_ppddl()


@pytest.mark.slow
def test_zz_a_good_share_of_mutants_are_still_valid():
    """Run after the slow fuzzers above (file order): a fuzzer that only ever produced garbage would
    test nothing but the first check of each reader."""
    total = sum(sum(c.values()) for c in OUTCOMES.values())
    valid = sum(c["valid"] for c in OUTCOMES.values())
    assert total >= 10_000, OUTCOMES
    assert valid / total >= 0.3, OUTCOMES


# ----------------------------------------------------------------------------- through the CLI
def _cli_case(kind: str, seeds: dict[str, Path], tmp: Path, text: str) -> list[str] | None:
    """The command that reads a file of ``kind``, with the mutant in place; None if the mutant is
    valid (the command would then do its real work, which is not what this fuzzes)."""
    import shutil

    tmp.mkdir(parents=True, exist_ok=True)
    if kind == "ppddl":
        from groundsym.ppddl.parser import parse_text

        (tmp / "d.ppddl").write_text(text)
        if check("ppddl", lambda: parse_text(text, "<fuzz>")):
            return None
        return ["simulate", "--domain", str(tmp / "d.ppddl"), "-o", str(tmp / "out.json")]
    if _json_case(kind, seeds, tmp, text):
        return None
    path = tmp / seeds[kind].name
    if kind in ("rules", "reward"):       # a model directory without a manifest, so the reader itself runs
        model = tmp / "model"
        shutil.rmtree(model, ignore_errors=True)
        shutil.copytree(seeds[kind].parent, model)
        (model / "manifest.json").unlink(missing_ok=True)
        shutil.copy(path, model / seeds[kind].name)
        return ["score", str(model), str(seeds["symbolic"])]
    return {"traces": ["learn", str(path), "-o", str(tmp / "M"), "--evals", "16", "--restarts", "2"],
            "symbolic": ["learn", str(path), "-o", str(tmp / "M")],
            "symbols": ["abstract", str(DATA / "tower_small.json"), "--symbols", str(path), "-o", str(tmp / "a.json")],
            "checkpoint": ["learn", str(DATA / "tower_small.json"), "-o", str(tmp / "M"), "--evals", "16",
                           "--restarts", "2", "--checkpoint", str(path)]}[kind]


CLI_KINDS = ["traces", "symbolic", "symbols", "rules", "reward", "checkpoint", "ppddl"]


def _cli_property(n: int, subprocess_run: bool):
    @settings(max_examples=n, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    @given(data=st.data())
    def run(seeds, tmp_path_factory, capsys, data):
        kind = data.draw(st.sampled_from(CLI_KINDS))
        text = data.draw(ppddl_mutant() if kind == "ppddl" else json_mutant(json.loads(seeds[kind].read_text())))
        argv = _cli_case(kind, seeds, tmp_path_factory.getbasetemp() / f"cli-{kind}", text)
        if argv is None:
            return
        if subprocess_run:
            import subprocess
            import sys

            p = subprocess.run([sys.executable, "-m", "groundsym.cli", *argv, "--quiet"] if argv[0] == "learn"
                               else [sys.executable, "-m", "groundsym.cli", *argv], cwd=ROOT, capture_output=True,
                               text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})
            status, err = p.returncode, p.stderr
        else:
            from groundsym.cli import main

            capsys.readouterr()
            status, err = main(argv), capsys.readouterr().err
        assert status == 2 and err.count("\n") == 1 and "Traceback" not in err, (argv, status, err)
        assert err.startswith(f"groundsym {argv[0]}: error: "), err
    return run


_fast_cli = _cli_property(30, subprocess_run=False)
_slow_cli = _cli_property(300, subprocess_run=True)


def test_cli_refuses_bad_files_in_one_line(seeds, tmp_path_factory, capsys):
    """In-process ``main()`` in the default run; the slow run below starts a process per input."""
    _fast_cli(seeds, tmp_path_factory, capsys)


@pytest.mark.slow
def test_cli_processes_refuse_bad_files_in_one_line(seeds, tmp_path_factory, capsys):
    _slow_cli(seeds, tmp_path_factory, capsys)


# ----------------------------------------------------------------------------- Gymnasium
# The constructors take keywords straight from ``gymnasium.make``: each either builds an environment
# or raises UserError in one line naming the keyword (docs/gymnasium.md); ``step`` either steps or
# raises ValueError (a bad action) or RuntimeError (before reset, after the end, after close), in
# one line. Any other exception (a TypeError from deep inside, pybullet's errors) fails.
GYM_ODD = st.one_of(st.sampled_from([None, True, False, 0, -1, 1, 2, 3, 4, 3.5, 3.0, -0.0, float("nan"), float("inf"),
                                     1e308, 10 ** 23, "", "3", "3.5", "x", "rgb_array", "ansi", [], [3], {}, (1, 2),
                                     b"3", np.int64(2), np.float64(2.0)]),
                    st.integers(-5, 20), st.floats(-10, 10), st.text(max_size=5))
GYM_KEYS = {"tower": ["cubes", "big", "balls", "cans", "noise", "small_size", "features", "steps", "model",
                      "render_mode", "render_width", "render_height", "colour"],
            "bowling": ["pins", "spots", "shuffle_ids", "noise", "speed", "timestep", "steps", "model",
                        "render_mode", "render_width"],
            "ppddl": ["domain", "problem", "steps", "render_mode", "render_width", "render_height", "colour"]}
GYM_BASE = {"tower": {"cubes": 2}, "bowling": {"pins": 2},
            "ppddl": {"domain": str(ROOT / "domains" / "reference" / "blocksworld" / "domain.ppddl"),
                      "problem": str(ROOT / "domains" / "reference" / "blocksworld" / "p01.ppddl")}}
GYM_OUTCOMES: dict[str, int] = {"built": 0, "refused": 0}


def _one_line(exc: BaseException) -> None:
    assert str(exc).strip() and "\n" not in str(exc).strip(), f"not one line: {type(exc).__name__}: {exc!r}"


def _gym_case(kind: str, edits: dict[str, Any], actions: list[Any], seed: Any) -> None:
    import gymnasium

    from groundsym.gym import PPDDLGymEnv, SimGymEnv

    kwargs = {**GYM_BASE[kind], **edits}
    with time_bound(TIME_LIMIT):
        try:
            env = PPDDLGymEnv(**kwargs) if kind == "ppddl" else SimGymEnv(kind, **kwargs)
        except UserError as exc:
            _one_line(exc)
            GYM_OUTCOMES["refused"] += 1
            return
        GYM_OUTCOMES["built"] += 1
        try:
            for action in actions:
                try:
                    env.step(action)
                except (ValueError, RuntimeError) as exc:
                    _one_line(exc)
                    if "reset" in str(exc) or "ended" in str(exc):
                        try:
                            env.reset(seed=seed)
                        except gymnasium.error.Error as bad_seed:      # Gymnasium's own check of the seed
                            _one_line(bad_seed)
                            env.reset(seed=0)
        finally:
            env.close()
        with pytest.raises(RuntimeError, match="^the environment is closed$"):
            env.step(0)


def _gym_property(examples: int):
    @settings(max_examples=examples, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    @given(kind=st.sampled_from(sorted(GYM_KEYS)), data=st.data())
    def run(kind: str, data) -> None:
        edits = data.draw(st.dictionaries(st.sampled_from(GYM_KEYS[kind]), GYM_ODD, max_size=3))
        actions = data.draw(st.lists(st.one_of(st.integers(-2, 12), GYM_ODD), max_size=4))
        seed = data.draw(st.one_of(st.none(), st.integers(0, 2 ** 31), GYM_ODD))
        _gym_case(kind, edits, actions, seed)
    return run


_fast_gym = _gym_property(FAST * 2)
_slow_gym = _gym_property(SLOW // 2)


def test_gym_constructors_and_step_work_or_refuse_in_one_line():
    _fast_gym()
    assert GYM_OUTCOMES["built"] and GYM_OUTCOMES["refused"], GYM_OUTCOMES


@pytest.mark.slow
def test_gym_constructors_and_step_many():
    _slow_gym()
