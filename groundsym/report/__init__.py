"""A learned model as one self-contained HTML page (``groundsym report``).

Why: for teaching and for inspecting what was learned, a person would rather look than read JSON.
The page shows the symbols in words with their plots, their F1 against ground truth, the rules as
cards, the reward model, the PPDDL domain with each predicate's meaning, and a planned episode as
a filmstrip; :mod:`.page` makes it self-contained, :mod:`.sections` and :mod:`.filmstrip` fill it.
"""

from .filmstrip import EpisodeView, read_episode, read_frames
from .page import Section, page

__all__ = ["EpisodeView", "Section", "page", "read_episode", "read_frames"]
