"""LeRobot datasets, policies and their evaluation (paper 3.6, A.4, A.6).

Datasets: :mod:`.frames` picks the control steps a dataset keeps, :mod:`.convert` writes them
with LeRobot's own ``LeRobotDataset`` API, :mod:`.stats` summarises a converted dataset.
Training: :mod:`.train`. Serving: :mod:`.protocol`, :mod:`.server`, :mod:`.client`.
Evaluation: :mod:`.evaluate` (one closed-loop episode), :mod:`.runner` (many: suites, resume,
workers, dead servers), :mod:`.results` (run folders and summaries), :mod:`.significance`
(intervals and tests), :mod:`.report` (``pipette eval report``).
"""
