"""Robot-agnostic motion skills that read the world and the assets' semantics (see
:mod:`pipette_cli.skills.runtime`), and the runner of expert programs built from them
(:mod:`pipette_cli.skills.program`)."""
