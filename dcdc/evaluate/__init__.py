"""Neural rollout, scores against SPH ground truth, and the `simulate` / `evaluate` commands."""

# Whether a neural rollout applies the SPH solver's wall contact after each network step
# (dcdc.evaluate.rollout, "Wall contact") unless told otherwise: the default of
# NeuralSimulator, `dcdc simulate`, `dcdc evaluate` and `dcdc demo`.
CONTACT_DEFAULT = True
