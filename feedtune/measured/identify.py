"""``feedtune identify``: a plant from measured data, with units and uncertainty.

:func:`identify` fits one model (:mod:`feedtune.measured.models`) to every data set of an
axis together (:mod:`feedtune.measured.fit`), reads the model's named parameters with
their standard errors, and writes the plant block ``feedtune tune`` takes. Nothing flows
back: the tuner never sees this module, only the plant block.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from feedtune.measured.data import DataError, FrequencyResponseData, MeasuredData
from feedtune.measured.fit import Fit, FitError, fit, hurwitz
from feedtune.measured.models import Model

#: relative step of the central differences that carry the coefficients' covariance to the
#: named parameters (delta method); the coefficients are known to ≈1e-4 relative or worse,
#: so the truncation error (step²) and the rounding error (1e-16/step) are both negligible
DELTA_STEP = 1e-6

UNCERTAINTY = ("standard error: √diag of s²(JᵀJ)⁻¹ of the output-error fit (J its "
               "Jacobian, s² the residual variance), carried to each named parameter by "
               "its derivative (delta method); valid for independent output noise and a "
               "model of the right structure")


@dataclass(frozen=True)
class Identification:
    """An identified plant.

    Attributes
    ----------
    model : Model
    fit : Fit
    data : list of MeasuredData
    units : dict
        ``position`` (m or rad) and ``input`` (the command's unit).
    values, standard_errors : dict
        The model's named parameters [their units] and standard errors [same units].
    plant : dict
        The plant block for a spec.
    """

    model: Model
    fit: Fit
    data: list
    units: dict
    values: dict[str, float]
    standard_errors: dict[str, float]
    plant: dict

    def to_dict(self) -> dict:
        """The JSON ``feedtune identify`` prints."""
        described = self.model.parameters(self.units)
        num, den = self.fit.model.transfer()
        return {
            "model": self.model.name,
            "options": self.model.options,
            "units": self.units,
            "parameters": {name: {"value": self.values[name],
                                  "standard_error": self.standard_errors[name],
                                  "unit": p.unit, "description": p.description}
                           for name, p in described.items()},
            "transfer_function": {
                "numerator": num.tolist(), "denominator": den.tolist(),
                "dead_time": self.fit.model.dead_time,
                "description": f"command [{self.units['input']}] → position "
                               f"[{self.units['position']}], powers of s highest first; "
                               "dead time [s]"},
            "lumped": self.model.lumped,
            "plant": self.plant,
            "data": [_data_entry(d, nrmse, offset) for d, nrmse, offset
                     in zip(self.data, self.fit.nrmse, self.fit.offsets)],
            "fit": {"method": _method(self.data, self.model),
                    "linear_solves": self.fit.linear_iterations,
                    "output_error_evaluations": self.fit.output_error_evaluations,
                    "residual_variance": self.fit.residual_variance,
                    "degrees_of_freedom": self.fit.degrees_of_freedom,
                    "stabilisation": self.fit.stabilisation or None,
                    "uncertainty": UNCERTAINTY},
        }


def _data_entry(d: MeasuredData, nrmse: float, offset: float | None) -> dict:
    entry = {"source": d.source,
             "kind": "frequency_response" if isinstance(d, FrequencyResponseData)
             else "time_series",
             "output": f"{d.output_kind} [{d.output_unit}]",
             "points": len(d.frequency_rad_s if isinstance(d, FrequencyResponseData)
                           else d.time_s),
             "nrmse": nrmse}
    if offset is not None:
        entry["output_offset"] = offset
    return entry


def _method(data, model: Model) -> str:
    parts = []
    if any(isinstance(d, FrequencyResponseData) for d in data):
        parts.append("frequency data: Levy, then Sanathanan–Koerner iterations")
    if not all(isinstance(d, FrequencyResponseData) for d in data):
        parts.append("time data: state-variable-filter equation error")
    grid = "; dead time on a grid" if model.structure.dead_time else ""
    return ("; ".join(parts) + " (cvxpy, Clarabel, a ≥ 0"
            + (", gain ≥ 0" if model.structure.positive_gain else "") + ")" + grid
            + "; then output error (scipy.optimize.least_squares)")


def _units(data: list[MeasuredData], model: Model) -> dict:
    """The position and command units every data set shares, checked against the model's."""
    first = data[0]
    position = first.output_unit.removesuffix("/s")
    for d in data:
        here = d.output_unit.removesuffix("/s")
        if here != position:
            raise DataError(d.source, 1, 1, f"output in {d.output_unit}, but "
                                            f"{first.source} is in {first.output_unit}: "
                                            "every data set of an axis has one position unit")
        if d.input_unit != first.input_unit:
            raise DataError(d.source, 1, 1, f"command in {d.input_unit}, but {first.source} "
                                            f"is in {first.input_unit}")
        if model.position_unit is not None and here != model.position_unit:
            raise DataError(d.source, 1, 1, f"model {model.name} is an axis in "
                                            f"{model.position_unit}, the data are in {here}")
        if model.input_unit is not None and d.input_unit != model.input_unit:
            raise DataError(d.source, 1, 1, f"model {model.name}'s gains are per "
                                            f"{model.input_unit}; the command is in "
                                            f"{d.input_unit}")
    return {"position": position, "input": first.input_unit}


def identify(data: list[MeasuredData], model: Model, max_dead_time: float | None = None,
             template: dict | None = None) -> Identification:
    """Fit ``model`` to every data set of one axis.

    Parameters
    ----------
    data : list of MeasuredData
        From :func:`feedtune.measured.data.read_data`.
    model : Model
    max_dead_time : float, optional
        Largest dead time searched [s] (models with a dead time); default: two turns of
        phase at the highest measured frequency, or 20 samples of a time series.
    template : dict, optional
        A plant block whose other fields (technique, compensators, controllers, …) the
        identified block keeps (:meth:`Model.block`).

    Raises
    ------
    DataError
        Data sets in different units, or not in the model's.
    FitError
        Too few points, unidentifiable parameters, an unstable fitted model, or a block
        (with the template's fields) the plant does not accept.
    """
    from feedtune.plants import PLANTS

    units = _units(data, model)
    result = fit(data, model.structure, max_dead_time)
    if not hurwitz(result.model.denominator[1:]):  # a_0 = 1
        raise FitError("the fitted model is unstable (a pole in the right half-plane): "
                       "the data do not support this model; try another order")
    structure = model.structure

    def named(p):
        r = structure.rational(p, 1.0)  # physical parameters: the scale at ω0 = 1
        return model.values(r.numerator, r.denominator, r.dead_time)

    values = named(result.parameters)
    jacobian = np.empty((len(values), len(result.parameters)))
    for i, p in enumerate(result.parameters):
        h = DELTA_STEP * max(abs(p), 1e-300)
        up, down = result.parameters.copy(), result.parameters.copy()
        up[i] += h
        down[i] -= h
        jacobian[:, i] = (named(up) - named(down)) / (2 * h)
    errors = np.sqrt(np.maximum(np.diag(jacobian @ result.covariance @ jacobian.T), 0.0))
    names = list(model.parameters(units))
    value_map = {n: float(v) for n, v in zip(names, values)}
    try:
        plant = model.block(value_map, units, template)
        PLANTS[plant["type"]].Params.model_validate(plant)
    except ValueError as exc:
        raise FitError(f"the identified plant block is not a valid {model.name} plant: "
                       f"{exc}") from None
    return Identification(model, result, list(data), units, value_map,
                          {n: float(e) for n, e in zip(names, errors)}, plant)


__all__ = ["DataError", "FitError", "Identification", "identify"]
