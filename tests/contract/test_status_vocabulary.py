"""One status vocabulary (feedtune/schema/status.py): no module writes a status as a string of
its own.

A status set or compared anywhere in ``feedtune/`` (``status=...``, ``"status": ...``,
``Outcome(...)``, ``status == ...``) is one of the names of :mod:`feedtune.schema.status`, never a
string literal, so a new status or a typo cannot slip past the result's ``Literal``.
"""

from __future__ import annotations

import ast
from pathlib import Path
from typing import get_args

from contract_cases import PACKAGE_ROOT, package_trees
from feedtune.schema import status
from feedtune.schema.result import TuneResult

def _literal(node) -> bool:
    """A string written in place: a constant, or an f-string that starts with one."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return True
    return (isinstance(node, ast.JoinedStr) and bool(node.values)
            and isinstance(node.values[0], ast.Constant))


def _named_status(node) -> bool:
    name = node.id if isinstance(node, ast.Name) else getattr(node, "attr", "")
    return name == "status"


def _status_literals(tree: ast.AST) -> list[int]:
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.keyword) and node.arg == "status" and _literal(node.value):
            lines.append(node.lineno)
        elif isinstance(node, ast.Dict):
            lines += [v.lineno for k, v in zip(node.keys, node.values)
                      if isinstance(k, ast.Constant) and k.value == "status" and _literal(v)]
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
              and node.func.id == "Outcome" and node.args and _literal(node.args[0])):
            lines.append(node.lineno)
        elif isinstance(node, ast.Compare):
            sides = [node.left, *node.comparators]
            if any(_named_status(s) for s in sides) and any(_literal(s) for s in sides):
                lines.append(node.lineno)
        elif (isinstance(node, ast.Assign) and any(_named_status(t) for t in node.targets)
              and _literal(node.value)):
            lines.append(node.lineno)
    return lines


def test_no_status_literal_outside_the_vocabulary():
    found = []
    for path, tree in package_trees():
        if path == Path(status.__file__).resolve():
            continue
        found += [f"{path.relative_to(PACKAGE_ROOT)}:{line}" for line in _status_literals(tree)]
    assert not found, f"status strings written outside feedtune/schema/status.py: {found}"


def test_result_status_is_the_vocabulary():
    assert TuneResult.model_fields["status"].annotation is status.Status
    assert set(status.SOLVED) <= set(get_args(status.Status))
    assert not set(get_args(status.Status)) & set(get_args(status.BatchStatus))
    names = (status.OPTIMAL, status.ACCEPTABLE, status.INFEASIBLE, status.ITERATION_LIMIT,
             status.TIME_LIMIT, status.ERROR)
    assert names == get_args(status.Status)
