"""The tuner: builds and solves the NLP from a loop factory and metric callables.

It imports neither ``feedtune.plants`` nor ``feedtune.objectives`` (tests enforce this).
"""

from feedtune.tuner.nlp import Problem
from feedtune.tuner.types import Bound, Outcome, Settings, Term, Variable

__all__ = ["Bound", "Outcome", "Problem", "Settings", "Term", "Variable"]
