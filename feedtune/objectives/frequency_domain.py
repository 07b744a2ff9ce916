"""What the frequency-domain metrics share: which loops they read, and |T|², L(jω)."""

from feedtune.lazy import ca


def has_frequency_band(loop) -> bool:
    """The loop declares the band [rad/s] its frequency responses live in."""
    return getattr(loop, "frequency_band", None) is not None


def has_open_loop(loop) -> bool:
    return has_frequency_band(loop) and hasattr(loop, "open_loop_response")


def normalised_gain_squared(loop):
    """ω ↦ |T(jω)/T(0)|² [1]: the closed loop normalised to unit DC gain (Bhatia Ch. IV A)."""
    dc = loop.dc_gain()

    def gain(omega):
        re, im = loop.frequency_response(omega)
        return (re**2 + im**2) / dc**2

    return gain


def phase_crossover_indicator(loop):
    """ω ↦ −Im L/|L| [1]: +1 at low ω for a type-1 loop, 0 where the phase reaches −180°."""
    def indicator(omega):
        re, im = loop.open_loop_response(omega)
        return -im / ca.sqrt(re**2 + im**2)

    return indicator


def log_open_loop_gain_squared(loop):
    """ω ↦ ln |L(jω)|² [1]: positive below the gain crossover of a type-1 loop."""
    def gain(omega):
        re, im = loop.open_loop_response(omega)
        return ca.log(re**2 + im**2)

    return gain
