"""Independent checks of a tuned design with numpy/scipy only (no CasADi)."""
