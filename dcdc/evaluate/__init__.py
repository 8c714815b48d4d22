"""Neural rollout, scores against SPH ground truth, and the `simulate` / `evaluate` commands."""
