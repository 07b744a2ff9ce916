"""Independent checks of a tuned design with numpy/scipy only (no CasADi)."""

from feedtune.validate.block import validate_result, warning_lines  # noqa: F401
