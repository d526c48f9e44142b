"""LeRobot datasets and training (paper 3.6, appendix D.1): the package that uses lerobot.

:mod:`.frames` picks the control steps a dataset keeps, :mod:`.convert` writes them with LeRobot's
own ``LeRobotDataset`` API, :mod:`.stats` summarises a converted dataset, :mod:`.train` launches
``lerobot-train``. Serving a policy is :mod:`pipette_cli.serving`; evaluating one,
:mod:`pipette_cli.evaluation`.
"""
