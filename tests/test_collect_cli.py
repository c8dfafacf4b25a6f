"""`groundsym collect` and `groundsym render` through groundsym.cli.main: files, metadata, errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from groundsym.cli import main
from groundsym.collect import collect_traces, trace_seeds
from groundsym.errors import UserError
from groundsym.traces import read_traces, write_traces
from sims.tower import TowerSim

from conftest import DATA


def test_collect_writes_what_collect_traces_makes(tmp_path, capsys):
    out = tmp_path / "t.json"
    argv = ["collect", "--sim", "tower", "--traces", "2", "--length", "3", "--seed", "4",
            "--sim-opt", "cubes=3", "--sim-opt", "big=1 balls=1", "-o", str(out)]
    assert main(argv) == 0
    assert "collect tower" in capsys.readouterr().err          # the progress bar
    ds = read_traces(out)
    meta = ds.meta
    assert meta["sim"] == "tower" and meta["seed"] == 4
    assert meta["options"] == {"cubes": 3, "big": 1, "balls": 1, "noise": 0.0075, "small_size": 0.04,
                               "big_size": 0.05, "ball_size": 0.045}
    assert meta["command"].endswith("-o " + str(out)) and meta["version"]
    assert ds.feature_names == ("x", "y", "z", "size")
    assert ds.primitives == {"closeHandAround": 1, "openHandOver": 1}
    assert len(ds.traces) == 2 and ds.n_transitions == 6
    with TowerSim(cubes=3, big=1, balls=1) as sim:
        ref = collect_traces(sim, 2, 3, 4, progress=False)
    for got, want in zip(ds.traces, ref.traces):
        assert got.objects == ("o1", "o2", "o3", "o4")
        assert got.actions == want.actions
        for x, y in zip(got.scenes, want.scenes):
            np.testing.assert_array_equal(x.features, y.features)
            assert x.truth == y.truth
    # a step's reward is the reward of that step's scene; the final scene's reward is kept too
    doc = json.loads(out.read_text())
    assert [s["reward"] for s in doc["traces"][0]["steps"]] == [sc.reward for sc in ref.traces[0].scenes[:-1]]
    assert doc["traces"][0]["final"]["reward"] == ref.traces[0].scenes[-1].reward


def test_trace_seeds_do_not_depend_on_the_number_of_traces():
    a = trace_seeds(7, 2)
    b = trace_seeds(7, 5)
    assert [s for s, _ in a] == [s for s, _ in b[:2]]
    assert a[1][1].integers(1 << 30) == b[1][1].integers(1 << 30)


def test_small_traces_file_round_trips(tmp_path):
    ds = read_traces(DATA / "tower_small.json")
    assert len(ds.traces) == 4 and all(len(t) == 10 for t in ds.traces)
    assert all(t.objects == tuple(f"o{i}" for i in range(1, 8)) for t in ds.traces)
    write_traces(tmp_path / "again.json", ds)
    again = read_traces(tmp_path / "again.json")
    assert json.loads((tmp_path / "again.json").read_text())["traces"] == \
        json.loads((DATA / "tower_small.json").read_text())["traces"]
    assert again.meta == ds.meta


def test_truncated_traces_file_is_a_user_error(tmp_path):
    text = (DATA / "tower_small.json").read_text()
    bad = tmp_path / "cut.json"
    bad.write_text(text[: len(text) // 2])
    with pytest.raises(UserError, match="cut.json"):
        read_traces(bad)


@pytest.mark.parametrize("args, words", [
    (["--sim", "towr"], "unknown simulation"),
    (["--sim", "tower", "--sim-opt", "cubez=3"], "cubez"),
    (["--sim", "tower", "--sim-opt", "noise=much"], "noise"),
    (["--sim", "tower", "--sim-opt", "big=9"], "big"),
    (["--sim", "tower", "--sim-opt", "cubes"], "key=value"),
])
def test_collect_errors_are_one_line_exit_2(tmp_path, capsys, args, words):
    out = tmp_path / "t.json"
    assert main(["collect", *args, "-o", str(out)]) == 2
    _one_line(capsys, words)
    assert not out.exists()


@pytest.mark.parametrize("args, words", [(["--traces", "0"], "--traces"), (["--length", "-2"], "--length"),
                                         (["--seed", "x"], "--seed")])
def test_collect_usage_errors_exit_2(tmp_path, capsys, args, words):
    with pytest.raises(SystemExit) as exc:
        main(["collect", "--sim", "tower", *args, "-o", str(tmp_path / "t.json")])
    assert exc.value.code == 2
    _one_line(capsys, words)


def _one_line(capsys, words: str) -> None:
    err = capsys.readouterr().err.strip()
    assert words in err and "\n" not in err and "Traceback" not in err


def test_unwritable_output_fails_before_collecting(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["collect", "--sim", "tower", "--traces", "50", "-o", str(blocker / "t.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "cannot write" in err and "\n" not in err
    assert main(["render", "--sim", "tower", "-o", str(tmp_path)]) == 2
    assert "is a directory" in capsys.readouterr().err


def test_render_draws_the_cell(tmp_path):
    import matplotlib.image as mpimg

    out = tmp_path / "scene.png"
    assert main(["render", "--sim", "tower", "--seed", "2", "--width", "320", "--height", "240", "-o", str(out)]) == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = mpimg.imread(out)[:, :, :3]
    assert img.shape == (240, 320, 3)
    red = (img[:, :, 0] > 0.6) & (img[:, :, 1] < 0.35) & (img[:, :, 2] < 0.35)   # small cubes are red
    blue = (img[:, :, 2] > 0.6) & (img[:, :, 0] < 0.35)                          # big cubes are blue
    assert red.sum() > 20 and blue.sum() > 20
    # without cubes there is nothing red or blue: the colours come from the objects
    out2 = tmp_path / "balls.png"
    assert main(["render", "--sim", "tower", "--sim-opt", "cubes=0 balls=2", "--width", "320",
                 "--height", "240", "-o", str(out2)]) == 0
    img2 = mpimg.imread(out2)[:, :, :3]
    assert ((img2[:, :, 2] > 0.6) & (img2[:, :, 0] < 0.35)).sum() == 0
