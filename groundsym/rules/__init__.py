"""Noisy indeterministic deictic (NID) rules: the model (:mod:`.model`) and its learner."""
