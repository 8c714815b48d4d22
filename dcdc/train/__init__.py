"""Training the learned simulator (``dcdc train``; docs/training.md).

Modules kept apart, one job each: ``config`` (typed TrainConfig: TOML + ``--set``),
``curriculum`` (stages by density ratio, paper §3.4), ``sampler`` (windows, augmentation,
one concatenated batch), ``loss`` (unrolled neighbour-weighted position loss),
``trainer`` (loop, validation, logs, checkpoints, resume, DDP), ``cli``.
"""
