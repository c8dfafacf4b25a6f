"""Are a rule set's outcome probabilities honest? Expected calibration error and reliability diagram.

A NID rule that says "this release lands the cube 70% of the time" is only useful to a planner if,
among held-out transitions it covers, the release lands about 70% of the time. The log-likelihood
(:mod:`groundsym.rules.evaluate`) mixes that with coverage and impossible transitions; calibration
asks the question alone, as classifiers are checked (Guo, Pleiss, Sun & Weinberger 2017, *On
calibration of modern neural networks*, ICML; Naeini, Cooper & Hauskrecht 2015 for the binned
estimator):

* every held-out transition ``(s, a, s')`` covered by a non-default rule ``r`` (binding ``b``)
  gives one *prediction* per outcome ``o_i`` of ``r``: the probability ``p_i`` against whether it
  happened (``o_i`` applied to ``s`` under ``b`` gives ``s'``);
* predictions fall into 10 equal-width bins of ``p`` (``[0, 0.1), ..., [0.9, 1]``);
* ``ECE = sum_bins n_bin / N * |mean p in bin - share that happened in bin|``.

A perfectly calibrated model does not score 0 on finite data: each bin's observed share scatters
around its mean probability. ``floor`` is the ECE such a model would show on these very
predictions, by consistency resampling (Broecker & Smith 2007, *Increasing the reliability of
reliability diagrams*, Weather and Forecasting 22): outcomes drawn from the covering rules' own
probabilities (noise included), the ECE averaged over ``FLOOR_DRAWS`` draws with a fixed seed. An
ECE near its floor says the data cannot show miscalibration; above it, the rules are off.

The noise outcome is not a prediction of a specific successor, so it is not binned: its mass is
reported beside the ECE against the share of covered transitions no outcome explains. Transitions
left to a default rule are counted, not binned (the default rule predicts "no change or noise",
not an outcome of a rule). docs/rules.md, "Calibration", has the measured figures.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ..fileio import atomic_write_bytes
from ..symbolic_traces import SymbolicDataset
from .model import RuleSet

BINS = 10
FLOOR_DRAWS = 200


@dataclass(frozen=True)
class Calibration:
    """Binned calibration of outcome probabilities; ``count[k]``, ``mean_p[k]``, ``observed[k]``
    describe bin ``k`` (``[k/10, (k+1)/10)``, the last one closed); empty bins hold 0."""

    ece: float
    predictions: int
    covered: int                     # transitions a non-default rule covered
    default_covered: int             # transitions left to a default rule (not binned)
    noise_predicted: float           # mean noise mass of the covering rules
    noise_observed: float            # share of covered transitions no outcome explains
    floor: float                     # ECE of a perfectly calibrated model on these predictions
    count: tuple[int, ...]
    mean_p: tuple[float, ...]
    observed: tuple[float, ...]

    def to_doc(self) -> dict[str, Any]:
        return {"ece": self.ece, "floor": self.floor, "bins": BINS, "predictions": self.predictions, "covered": self.covered,
                "default_covered": self.default_covered, "noise_predicted": self.noise_predicted,
                "noise_observed": self.noise_observed,
                "reliability": [{"bin": k, "count": n, "mean_p": p, "observed": o}
                                for k, (n, p, o) in enumerate(zip(self.count, self.mean_p, self.observed))]}

    def __str__(self) -> str:
        return (f"expected calibration error {self.ece:.4f} (floor {self.floor:.4f}) over {self.predictions} outcome predictions "
                f"({self.covered} covered transitions, {self.default_covered} left to default rules); "
                f"noise mass {self.noise_predicted:.3f} predicted, {self.noise_observed:.3f} unexplained")


def expected_calibration_error(probs: np.ndarray, happened: np.ndarray, bins: int = BINS) -> tuple[
        float, np.ndarray, np.ndarray, np.ndarray]:
    """ECE of predictions ``probs`` (in [0, 1]) against 0/1 outcomes ``happened``, with ``bins``
    equal-width bins weighted by count; also each bin's count, mean probability and observed share."""
    probs = np.asarray(probs, dtype=float)
    happened = np.asarray(happened, dtype=float)
    if probs.shape != happened.shape or probs.ndim != 1:
        raise ValueError("probs and happened must be 1-d arrays of the same length")
    which = np.minimum((probs * bins).astype(int), bins - 1)
    count = np.bincount(which, minlength=bins)
    sum_p = np.bincount(which, weights=probs, minlength=bins)
    sum_y = np.bincount(which, weights=happened, minlength=bins)
    safe = np.maximum(count, 1)
    mean_p, observed = sum_p / safe, sum_y / safe
    n = len(probs)
    ece = float(np.sum(count / n * np.abs(mean_p - observed))) if n else 0.0
    return ece, count, mean_p, observed


def calibration(rs: RuleSet, ds: SymbolicDataset, bins: int = BINS) -> Calibration:
    """Calibration of ``rs``'s outcome probabilities on the transitions of ``ds`` (module docstring)."""
    return pooled_calibration([(rs, ds)], bins)


def pooled_calibration(pairs: Iterable[tuple[RuleSet, SymbolicDataset]], bins: int = BINS) -> Calibration:
    """Calibration of several models, each on its own held-out data, in one set of bins: errors
    that differ in sign from model to model (too few training examples) average out here, a bias
    every model shares (a prior, the noise mass) does not."""
    probs: list[float] = []
    happened: list[bool] = []
    dists: list[tuple[float, ...]] = []
    covered = default = 0
    noise_p = noise_seen = 0.0
    for rs, ds in pairs:
        for tr in ds.traces:
            for s, a, s2 in tr.transitions():
                rule, b = rs.covering(s, a, tr.objects)
                if rule is None:
                    default += 1
                    continue
                covered += 1
                hits = [o.apply(s, b) == s2 for o in rule.outcomes]
                probs.extend(rule.probs)
                happened.extend(hits)
                noise_p += rule.noise
                noise_seen += not any(hits)
                dists.append(rule.probs)
    ece, count, mean_p, observed = expected_calibration_error(np.array(probs), np.array(happened), bins)
    return Calibration(ece, len(probs), covered, default, noise_p / max(covered, 1), noise_seen / max(covered, 1),
                       resampled_floor(dists, bins), tuple(int(c) for c in count), tuple(float(p) for p in mean_p),
                       tuple(float(o) for o in observed))


def resampled_floor(dists: list[tuple[float, ...]], bins: int = BINS, draws: int = FLOOR_DRAWS,
                    seed: int = 0) -> float:
    """Mean ECE when each prediction's outcome is drawn from its own rule's distribution."""
    if not dists:
        return 0.0
    width = max(len(d) for d in dists) + 1                      # outcomes, then noise
    table = np.zeros((len(dists), width))
    real = np.zeros((len(dists), width), dtype=bool)
    for i, d in enumerate(dists):
        table[i, :len(d)] = d
        table[i, -1] = max(0.0, 1.0 - sum(d))
        real[i, :len(d)] = True
    cum = np.cumsum(table, axis=1)
    cum[:, -1] = np.inf
    rng = np.random.default_rng(seed)
    probs = table[real]
    total = 0.0
    for _ in range(draws):
        drawn = (rng.random(len(dists))[:, None] < cum).argmax(axis=1)
        hit = np.arange(width)[None, :] == drawn[:, None]
        total += expected_calibration_error(probs, hit[real].astype(float), bins)[0]
    return total / draws


def reliability_png(cal: Calibration, title: str = "") -> bytes:
    """A reliability diagram: each bin's observed share against its mean predicted probability
    (the diagonal is perfect calibration), with the bin counts below. A PNG."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    k = len(cal.count)
    edges = np.linspace(0.0, 1.0, k + 1)
    full = np.array(cal.count) > 0
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(4.8, 5.6), sharex=True,
                                      gridspec_kw={"height_ratios": [3, 1]})
    top.plot([0, 1], [0, 1], ls="--", c="0.5", lw=1, label="perfect")
    top.bar(edges[:-1][full], np.array(cal.observed)[full], width=1.0 / k, align="edge", alpha=0.35,
            ec="tab:blue", color="tab:blue", label="observed share")
    top.plot(np.array(cal.mean_p)[full], np.array(cal.observed)[full], "o-", c="tab:red", ms=4,
             label="(mean p, observed)")
    top.set_ylabel("share that happened")
    top.set_xlim(0, 1)
    top.set_ylim(0, 1)
    top.legend(loc="upper left", fontsize=8)
    top.set_title((title + "\n" if title else "") + f"ECE {cal.ece:.4f}" + (f" (floor {cal.floor:.4f})" if np.isfinite(cal.floor) else "")
                  + f", {cal.predictions} predictions",
                  fontsize=9)
    bottom.bar(edges[:-1], cal.count, width=1.0 / k, align="edge", color="0.6", ec="0.3")
    bottom.set_yscale("symlog")
    bottom.set_xlabel("predicted outcome probability")
    bottom.set_ylabel("predictions")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def write_reliability_png(path: str | Path, cal: Calibration, title: str = "") -> None:
    atomic_write_bytes(path, reliability_png(cal, title))
