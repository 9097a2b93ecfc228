"""The exact head-on collision of the non-pulling linear spring-dashpot (physics.md section 2), for
tests that check the engine through its outer interfaces (runner, FMU)."""
import math


def clamped_restitution(e):
    """Realised restitution of a head-on collision whose dashpot is calibrated for e by the formula
    zeta = -ln e / sqrt(pi^2 + ln^2 e) but may not pull: the force k delta + c d(delta)/dt reaches zero
    before the overlap does, at w_d t = pi - atan2(2 zeta s, 1 - 2 zeta^2), s = sqrt(1 - zeta^2), and the
    pair then coasts apart at the overlap rate of that moment."""
    zeta = -math.log(e) / math.hypot(math.pi, math.log(e))
    s = math.sqrt(1 - zeta * zeta)
    phase = math.pi - math.atan2(2 * zeta * s, 1 - 2 * zeta * zeta)   # w_d t at release
    return math.exp(-zeta * phase / s) * (zeta / s * math.sin(phase) - math.cos(phase))


def clamped_separation_time(e, t_c):
    """Time from touching to parting in that collision, for the formula's t_c (the damped oscillator's
    half period, so w_d = pi / t_c): the release phase over w_d, then the coast out of the remaining
    overlap, which takes c / k = 2 zeta / w0."""
    zeta = -math.log(e) / math.hypot(math.pi, math.log(e))
    s = math.sqrt(1 - zeta * zeta)
    phase = math.pi - math.atan2(2 * zeta * s, 1 - 2 * zeta * zeta)
    w_d = math.pi / t_c
    return phase / w_d + 2 * zeta * s / w_d
