"""Authoring: descriptions -> task drafts (LLM backends behind one protocol, an offline parser),
deterministic layout and evaluator choice, registry YAML, ``--check``; text -> USD assets.

Entry points: :func:`pipette_cli.authoring.workflow.draft_task`,
:func:`pipette_cli.taskgen.check.check_task`, :func:`pipette_cli.taskgen.check.solve_check`,
:func:`pipette_cli.authoring.assets_new.draft_asset`. See ``docs/authoring.md``.
"""
