"""Scripted experts: a task's skill program (its ``expert:`` section, or one read off its success
criterion), run by :class:`~pipette_cli.skills.program.ProgramExpert`."""
