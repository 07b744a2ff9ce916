"""Measured data of an axis: reading it (``data``) and identifying a plant from it (``identify``)."""
