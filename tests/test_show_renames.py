"""``show --against`` suggests names from the ground-truth matches (hand-made matches)."""

from groundsym.commands.show import suggested_names
from groundsym.grounding import Match


def M(sym, arity, best, order, f1, neg=None, neg_f1=None):
    return Match(sym, arity, best, order, f1, f1, f1, neg, neg_f1)


def test_suggested_names():
    matches = [M("u1", 1, "inhand", "same", 0.95), M("u2", 1, "inhand", "same", 0.6),    # the better one wins
               M("u3", 1, "ontable", "same", 0.2, "inhand", 0.97),                       # learned "not in hand"
               M("b1", 2, "on", "swapped", 0.99), M("b2", 2, "above", "same", 0.3)]       # swapped / poor: none
    assert suggested_names(matches) == {"u1": "inhand", "u3": "not-inhand"}
