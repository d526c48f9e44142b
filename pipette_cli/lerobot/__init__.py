"""LeRobot datasets from recorded episodes (paper 3.6): conversion and dataset statistics.

:mod:`.frames` picks the control steps a dataset keeps, :mod:`.convert` writes them with
LeRobot's own ``LeRobotDataset`` API, :mod:`.stats` summarises a converted dataset.
"""
