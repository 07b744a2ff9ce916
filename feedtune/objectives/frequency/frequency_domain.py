"""What the frequency-domain metrics share: which loops they read, and |T|², L(jω).

A sampled loop's responses are those of the discrete loop at z = e^{jωT}, exact up to the
Nyquist frequency π/T. Its band (numbers, :attr:`feedtune.loops.loop.SampledLoop.frequency_band`)
reaches above π/T for every period T of the box, so one grid in rad/s serves a tunable T.
The responses are periodic in ω (period 2π/T) and symmetric about π/T, so a peak over the
band is the peak up to π/T (its aliases repeat the same values). A crossing that does not
happen under π/T does not happen at all; the functions crossings are located on take a
value below their level beyond π/T (:func:`below_nyquist`), so such a crossing is found at
π/T itself (a bandwidth "at Nyquist": the loop passes everything it can represent).
"""

from feedtune.expr import to_float
from feedtune.lazy import ca
from feedtune.loops.frequency import first_crossing
from feedtune.loops.protocols import Capability, Loop
from feedtune.loops.twin import OfLoop

#: what a sampled loop's crossing functions read beyond π/T by default: −1, below the
#: level of −Im L/|L| and of ln|L|² (0); |H/H(0)|² takes 0 there, below its level ½
BEYOND_NYQUIST = -1.0


def has_frequency_band(loop: Loop) -> bool:
    """The loop has frequency responses over a band [rad/s] (``frequency_band``)."""
    return loop.offers(Capability.FREQUENCY_RESPONSE)


def has_open_loop(loop: Loop) -> bool:
    """The loop has frequency responses and its open loop L (``open_loop_response``)."""
    return loop.offers(Capability.OPEN_LOOP)


def below_nyquist(loop: Loop, fn, beyond: float = BEYOND_NYQUIST):
    """``fn`` on a continuous loop; on a sampled loop ω ↦ fn(ω) for ωT ≤ π, else
    ``beyond`` (ω [rad/s], T the loop's period, a number or an expression). For the
    functions crossings are located on, never under a square root (its derivative at the
    constant would be ∞·0). An :class:`~feedtune.loops.twin.OfLoop` ``fn`` gives one."""
    if not loop.discrete:
        return fn
    if isinstance(fn, OfLoop):
        return OfLoop(_below_nyquist, loop, fn.factory, fn.args, beyond)
    return _cut(loop, fn, beyond)


def _below_nyquist(loop: Loop, factory, args: tuple, beyond: float):
    return _cut(loop, factory(loop, *args), beyond)


def _cut(loop: Loop, fn, beyond: float):
    def cut(omega):
        return ca.if_else(omega * loop.period <= ca.pi, fn(omega), beyond)

    return cut


def normalised_gain_squared(loop: Loop):
    """ω ↦ |T(jω)/T(0)|² [1]: the closed loop normalised to unit DC gain (Bhatia Ch. IV A);
    on a sampled loop at z = e^{jωT} (periodic in ω: take :func:`below_nyquist` of it to
    locate a crossing). An :class:`~feedtune.loops.twin.OfLoop`, as the functions below."""
    return OfLoop(_normalised_gain_squared, loop)


def _normalised_gain_squared(loop: Loop):
    dc = loop.dc_gain()

    def gain(omega):
        re, im = loop.frequency_response(omega)
        return (re**2 + im**2) / dc**2

    return gain


def phase_crossover_indicator(loop: Loop):
    """ω ↦ ±Im L/|L| [1], signed to be positive at the band's low end, 0 where the phase
    first crosses −180° (on a sampled loop also at π/T when L(−1) < 0: L is real there).

    −Im L/|L| is +1 at low ω for a type-1 loop (phase −90°) but −1 for a type-3 loop (a
    PID on a double integrator: phase −270°, rising through −180° at the lower phase
    crossover of a conditionally stable loop), so it is multiplied by the sign it has at
    the band's low end; the sign is the loop's structure, the same at every tunable value
    (the validator locates the same crossing on the unwrapped phase,
    feedtune.validate.continuous)."""
    return below_nyquist(loop, OfLoop(_phase_crossover_indicator, loop))


def _phase_crossover_indicator(loop: Loop):
    low = loop.frequency_band[0]

    def raw(omega):
        re, im = loop.open_loop_response(omega)
        return -im / ca.sqrt(re**2 + im**2)

    sign = ca.if_else(raw(low) >= 0, 1, -1)

    def indicator(omega):
        return sign * raw(omega)

    return indicator


def log_open_loop_gain_squared(loop: Loop):
    """ω ↦ ln |L(jω)|² [1]: positive below the gain crossover of a type-1 loop."""
    return below_nyquist(loop, OfLoop(_log_open_loop_gain_squared, loop))


def _log_open_loop_gain_squared(loop: Loop):
    def gain(omega):
        re, im = loop.open_loop_response(omega)
        return ca.log(re**2 + im**2)

    return gain


def as_number(omega):
    """``omega`` as a float when it is an expression of numbers only (a loop of numbers:
    the response at it is then plain float arithmetic, the same operations as evaluating
    its graph, without building one), else ``omega`` itself. A number (a DM: a
    crossing located in floats) is a float too."""
    if isinstance(omega, ca.DM) or (isinstance(omega, ca.MX) and omega.is_constant()):
        return to_float(omega)
    return omega


def gain_crossover(loop: Loop):
    """ω_c [rad/s]: the lowest ω where |L| = 1 (π/T on a sampled loop whose |L| stays above
    1 up to Nyquist). Located once per loop (kept in its ``__dict__``, as a cached
    property is): the crossover frequency and the phase margin share it."""
    found = loop.__dict__.get("_gain_crossover")
    if found is None:
        found = first_crossing(log_open_loop_gain_squared(loop), loop.frequency_band, 0.0,
                               "gain_crossover")
        loop.__dict__["_gain_crossover"] = found
    return found
