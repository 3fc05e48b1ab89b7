"""Why an experiment separates two candidates (or why none does, and what sensor would): the
physics of each pair of explanations the vocabulary can confuse, with the numbers of the case."""
from __future__ import annotations

import math

import numpy as np

from roboball.design.ramp import ANGLES_DEG
from roboball.design.rank import same_experiment
from roboball.reduced.models import model_for


def why(src, choice, best: dict, user: dict | None) -> str:
    """One paragraph: where the best experiment's predictions part and the mechanism behind it."""
    if src.kind == "ramp":
        return _ramp_why(src, choice, best, user)
    a, b = best["closest_pair"]
    at = ", ".join(f"{x:+.2f}" for x in best["release_from_rest_rad"])
    text = (f"released at {at} rad from rest, {a} and {b} differ by {best['rms_difference_rad']:.3g} rad RMS "
            f"({best['separation']:.3g} noise levels with the parameters' uncertainty)")
    if best.get("rolls_over"):
        text += (f"; {' and '.join(best['rolls_over'])} rolls the shell over there (its fit, made on the user's "
                 f"smaller swings, turns it past 90 degrees from rest, counted as held there): a recording shows "
                 f"at once which one it is, though not how far the fit is from the truth there")
    if user is not None and not same_experiment(user, best):
        text += (f", where a repeat of the user's release ({user['release_from_rest_rad'][0]:+.2f} rad) separates them by "
                 f"{user['separation']:.3g}")
    physics = _physics(src, choice, best)
    return text + ". " + physics if physics else text + "."


def _physics(src, choice, best: dict) -> str:
    labels = {c.label: c for c in choice.candidates}
    pair = set(best["closest_pair"])
    effects = {c.label: set(c.effects) for c in choice.candidates}
    amp = max(abs(x) for x in best["release_from_rest_rad"])
    if choice.about == "steer_joint":
        return ("With the pendulum free the shell carries less of the pendulum's restoring torque and inertia than "
                "clamped, and the pendulum's own swing beats against the shell's; the two settings part as the swing "
                "grows.")
    if pair == {"added_inertia", "linear_stiffness"} and "added_inertia" in effects["added_inertia"] \
            and "linear_stiffness" in effects["linear_stiffness"]:
        return _inertia_vs_stiffness(src, labels["added_inertia"], labels["linear_stiffness"], amp)
    if pair == {"viscous_damping", "quadratic_drag"}:
        return ("A viscous loss c qd takes the same share of a swing's energy whatever its speed; a quadratic drag "
                "c2 qd |qd| grows with speed: fitted to one swing speed they agree there, and part at faster "
                f"(larger, here {amp:.2f} rad) and slower swings.")
    if "rolling_resistance" in pair or "coulomb_friction" in pair:
        return ("A dry loss takes the same torque at every speed (linear amplitude loss), a velocity loss a torque "
                "that grows with speed (exponential loss): released further, the large swings show the difference.")
    if choice.about == "parameter":
        return "The parameter's two ends predict recordings that part where its effect acts most."
    return ""


def _ramp_why(src, choice, best: dict, user: dict | None) -> str:
    a, b = best["closest_pair"]
    unit = src.prep.unit
    diff = best[f"rms_difference_{src.prep.unit_key}"]
    text = (f"on a ramp of {best['ramp_angle_deg']:g} deg, {a} and {b} differ by {diff:.3g} {unit} RMS before the "
            f"first leaves the ramp ({best['separation']:.3g} noise levels of the averaged rate"
            + (", refitted" if best["refitted"] else ", the parameters' uncertainty included") + ")")
    if user is not None and user is not best:
        text += f", where a run on the user's {user['ramp_angle_deg']:g} deg ramp separates them by {user['separation']:.3g}"
    if best["ramp_angle_deg"] in (min(ANGLES_DEG), max(ANGLES_DEG)):
        edge = "steepest" if best["ramp_angle_deg"] == max(ANGLES_DEG) else "shallowest"
        text += (f"; the {edge} ramp considered: one beyond it may part them further, if the robot rolls there as "
                 "the model does")
    pair = {a, b}
    if pair == {"viscous_damping", "quadratic_drag"}:
        physics = ("A viscous loss brakes in proportion to the speed, a quadratic drag as its square: fitted to one "
                   "ramp's speeds they agree there, and part where the shell rolls faster or slower.")
    elif "stiction" in pair:
        physics = ("A breakaway that fades with speed (stiction with its width fitted: a flat to roll off) brakes the "
                   "start of a descent only; a loss that stays or grows with speed brakes it all the way: the ramp "
                   "that reaches other speeds over the same length tells them apart.")
    elif "rolling_resistance" in pair:
        physics = ("A rolling resistance brakes by the same torque at every speed, a velocity loss by one that grows "
                   "with speed: a steeper or shallower ramp moves the speeds they were matched at.")
    elif choice.about == "parameter":
        physics = "The parameter's two ends predict runs that part where its effect acts most."
    else:
        physics = ""
    return text + ". " + physics if physics else text + "."


def _inertia_vs_stiffness(src, inertia, spring, amp: float) -> str:
    """The amplitude at which gravity's restoring torque departs from a spring's."""
    m = model_for(src.kind)
    k_g, i0 = m.k_g, m.inertia
    di = inertia.values["added_inertia.delta_i"]
    k = spring.values["linear_stiffness.k"]
    ratio = math.sin(amp) / amp if amp else 1.0

    def period_ratio(a: float) -> float:
        r = math.sin(a) / a if a else 1.0
        w_i = math.sqrt(k_g * r / (i0 + di))
        w_k = math.sqrt(max(k_g * r + k, 1e-12) / i0)
        return w_i / w_k - 1.0

    small = period_ratio(0.05)
    big = period_ratio(amp)
    return (f"An added inertia (+{di:.3g} kg m^2) slows every swing by the same ratio; a spring's torque is k q at "
            f"every amplitude while gravity's is m g d sin q, so a negative stiffness ({k:.3g} N m/rad) takes a larger "
            f"share of the restoring torque the larger the swing: m g d sin(a)/a falls from {k_g:.3g} N m/rad at "
            f"small swings to {k_g * ratio:.3g} N m/rad at a = {amp:.2f} rad. The two swing frequencies (the "
            f"stiffness's relative to the inertia's) differ by {100 * small:+.2f}% at 0.05 rad and {100 * big:+.2f}% "
            f"at {amp:.2f} rad, and the difference accumulates swing after swing.")


SENSORS = {
    frozenset({"added_inertia", "linear_stiffness"}):
        "a torque sensor on the joint (or a known weight hung on the pendulum held still at an angle): a spring's "
        "torque is there at rest, an inertia's only under acceleration",
    frozenset({"viscous_damping", "quadratic_drag"}):
        "a rate sensor on the body (pipe_rate_rad_s / steer_rate_rad_s at a higher rate than the angle's "
        "derivative allows): the loss read directly against speed",
    "steer_joint": "an encoder on the steer joint (steer_angle_rad beside pipe_angle_rad): clamped it does not move",
}


def sensor(choice) -> str:
    """The sensor that would tell the candidates apart where no feasible experiment does."""
    if choice.about == "steer_joint":
        return SENSORS["steer_joint"]
    effects = frozenset(e for c in choice.candidates for e in [c.label] if "." not in e)
    return SENSORS.get(effects, "a direct measurement of the coordinate's torque against its angle and rate "
                                 "(a torque sensor, or a known applied torque), which the free response only "
                                 "shows integrated")


def largest_gap(g, a: str, b: str, w: int) -> tuple[float, float]:
    """(time s, difference rad) where candidates a and b part most in release w of grid g."""
    d = g.central[a][w] - g.central[b][w]
    i = int(np.argmax(np.abs(d)))
    return float(g.t[i]), float(d[i])
