"""Pydantic models of everything Pipette reads: task YAML, LLM output, CLI and network input.

No mujoco or pxr import happens here, so specs can be checked anywhere.
"""

from pipette_cli.specs.evaluators import EvaluatorSpec, evaluator_types, register_evaluator
from pipette_cli.specs.task import TaskSpec

__all__ = ["EvaluatorSpec", "TaskSpec", "evaluator_types", "register_evaluator"]
