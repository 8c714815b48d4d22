"""Neural rollout, scores against SPH ground truth, and the `simulate` / `evaluate` commands."""

# Whether a neural rollout applies the SPH solver's wall contact after each network step
# (dcdc.evaluate.rollout, "Wall contact") unless told otherwise: None = the model's own
# default (rollout.uses_contact: the checkpoint's "contact", True where it has none), the
# default of NeuralSimulator, `dcdc simulate`, `dcdc evaluate`, `dcdc suite score` and `dcdc demo`.
CONTACT_DEFAULT = None
