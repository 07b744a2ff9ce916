"""Base class of every spec and result model: frozen, strict about unknown keys and NaN."""

from pydantic import BaseModel, ConfigDict


class SpecModel(BaseModel):
    """Frozen pydantic model that rejects unknown keys and NaN/Infinity."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)
