"""What the blind benchmark conceals and how it is scored, shared by its clean cases
(diagnose_blind.py) and its real-like ones (real_like.py): the effects, their ranges and sets,
the draw, the visibility threshold and the scoring."""
from __future__ import annotations

import math
import statistics

import numpy as np

# ---- what is concealed, and how strongly ---------------------------------------------------
# Magnitudes: physically plausible for this robot and large enough to matter (each changes
# the free response by several times the sensors' 1 mrad quantisation).  Signed ranges draw a
# random sign.  Units: SI, the vocabulary's parameter names (roboball.physics.effects).
RANGES = {
    "steer_stand": {
        "coulomb_friction": {"tau_c": (0.15, 0.6)},             # N m (Table I: 0.45-0.65)
        "stiction": {"tau_s": (0.4, 0.9), "v_s": (0.01, 0.03)},  # N m above kinetic; rad/s
        "quadratic_drag": {"c2": (0.03, 0.15)},                  # N m s^2/rad^2
        "linear_stiffness": {"k": (1.0, 4.0, "signed")},         # N m/rad (m g d = 20.5)
        "cubic_stiffness": {"k3": (2.0, 8.0, "signed")},         # N m/rad^3
        "com_offset": {"delta": (0.015, 0.06, "signed")},        # rad
        "backlash": {"k_b": (3.0, 10.0), "b": (0.1, 0.3)},       # N m/rad, rad
    },
    "shell_rock": {
        "viscous_damping": {"c": (0.8, 4.0)},                    # N m s/rad (zeta 0.04-0.2)
        "rolling_resistance": {"tau_rr": (0.2, 1.0)},            # N m
        "quadratic_drag": {"c2": (1.0, 5.0)},                    # N m s^2/rad^2
        "linear_stiffness": {"k": (4.0, 20.0)},                  # N m/rad (K_eq = 21.9)
        "cubic_stiffness": {"k3": (20.0, 80.0, "signed")},       # N m/rad^3
        "com_offset": {"delta": (0.015, 0.05, "signed")},        # rad
    },
    "ramp": {
        "viscous_damping": {"c": (0.5, 3.0)},                    # N m s/rad on the drive rate
        "rolling_resistance": {"tau_rr": (0.5, 3.0)},            # N m
        "quadratic_drag": {"c2": (0.05, 0.3)},                   # N m s^2/rad^2
    },
}
BASE_VISCOUS = (0.05, 0.2)          # N m s/rad, stands
# With stiction, kinetic friction is drawn from 0.15-0.35 N m, so that the breakaway excess
# exceeds the amplitude lost per half swing (2 tau_c / m g d): the swings then stop earlier than
# kinetic friction alone would let them, which is what stiction means, IF they come to a stop
# within the recording.  With little kinetic friction they do not, and the breakaway torque
# only acts for an instant at each reversal: seeds 6 and 7 drew three such cases, where
# stiction changed the recording by 0.45-0.61 mrad RMS (about one noise level).  `visible_draw`
# redraws those.
WITH_STICTION = {"coulomb_friction": {"tau_c": (0.15, 0.35)}}
PRESSURES = (6.9, 10.3, 13.8, 17.2, 20.7)
SETS = {
    "steer_stand": [(), (), (), (),
                    ("coulomb_friction",), ("quadratic_drag",), ("linear_stiffness",),
                    ("cubic_stiffness",), ("com_offset",), ("backlash",),
                    ("coulomb_friction", "quadratic_drag"), ("coulomb_friction", "com_offset"),
                    ("coulomb_friction", "linear_stiffness"), ("coulomb_friction", "stiction"),
                    ("coulomb_friction", "stiction"),
                    ("cubic_stiffness", "com_offset"), ("quadratic_drag", "linear_stiffness")],
    "shell_rock": [(), (), (),
                   ("viscous_damping",), ("rolling_resistance",), ("quadratic_drag",), ("linear_stiffness",),
                   ("cubic_stiffness",), ("com_offset",),
                   ("viscous_damping", "linear_stiffness"), ("viscous_damping", "com_offset"),
                   ("rolling_resistance", "linear_stiffness"), ("quadratic_drag", "linear_stiffness"),
                   ("viscous_damping", "rolling_resistance")],
    "ramp": [(), (), (),
             ("viscous_damping",), ("rolling_resistance",), ("quadratic_drag",),
             ("rolling_resistance", "viscous_damping"), ("rolling_resistance", "quadratic_drag"),
             ("viscous_damping", "quadratic_drag")],
}
# stiction is concealed only together with Coulomb friction: breakaway ABOVE kinetic friction
# presupposes kinetic friction, and with viscous damping alone the swings never slow down
# enough within a recording for a breakaway torque to act (nothing to find).
RELEASES = {"steer_stand": (0.5, 0.9), "shell_rock": (0.2, 0.4)}     # rad from rest, alternating sign;
# steer swings stay inside the steer joint's limits (-1.57, +1.0 rad), which the reduced model does not have
FREE_S = 8.0


def magnitudes(kind: str, effects: tuple, rng: np.random.Generator) -> dict:
    drawn = {}
    for e in effects:
        drawn[e] = {}
        ranges = WITH_STICTION[e] if ("stiction" in effects and e in WITH_STICTION) else RANGES[kind][e]
        for p, spec in ranges.items():
            x = float(rng.uniform(spec[0], spec[1]))
            if len(spec) > 2 and rng.random() < 0.5:
                x = -x
            drawn[e][p] = round(x, 4)
    return drawn


def draw_cases(seed: int) -> list:
    rng = np.random.default_rng(seed)
    cases = []
    for kind, sets in SETS.items():
        for effects in sets:
            drawn = magnitudes(kind, effects, rng)
            case = {"id": f"{kind}-{len(cases):02d}", "kind": kind, "effects": drawn,
                    "seed": int(rng.integers(2 ** 31)), "draw_seed": seed}
            if kind == "steer_stand":
                case["viscous_c"] = round(float(rng.uniform(*BASE_VISCOUS)), 4)
            if kind != "steer_stand":
                case["pressure_kpa"] = float(rng.choice(PRESSURES))
            if kind in RELEASES:
                lo, hi = RELEASES[kind]
                sign = -1.0 if rng.random() < 0.5 else 1.0
                case["releases"] = [round(sign * (-1) ** i * float(rng.uniform(lo, hi)), 4) for i in range(3)]
            cases.append(case)
    return cases + large_swing_cases(seed, len(cases))


# ---- large swings under a noisy sensor -----------------------------------------------------------
# Coulomb friction with a quadratic drag, two releases near the steer joint's limits (about -1.2
# and +0.95 rad from rest; +1.2 would pass the +1.0 rad stop), a 2 mrad sensor.  On such a log
# each effect alone can fail the keep rule (the friction alone holds out worse than the
# baseline, the drag alone is absorbed by the viscous coefficient), so a search that prunes
# before it grows the pair misses both (issue 48: reported as Coulomb alone, or nothing).  Drawn
# from a stream of their own, after the others: the 40 cases above do not change.
# The magnitudes are the low ends of the stand's ranges: where each effect alone changes the fit
# least and fails the keep rule first (0.2 N m with 0.04 N m s^2/rad^2 gave nothing before).
LARGE_SWINGS = {"n": 3, "releases": ((-1.25, -1.1), (0.9, 0.97)), "angle_noise_rad": 2e-3,
                "ranges": {"coulomb_friction": {"tau_c": (0.15, 0.25)}, "quadratic_drag": {"c2": (0.03, 0.05)}}}


def large_swing_cases(seed: int, first: int) -> list:
    rng = np.random.default_rng([seed, 48])
    out = []
    for i in range(LARGE_SWINGS["n"]):
        effects = {e: {p: round(float(rng.uniform(*r)), 4) for p, r in ranges.items()}
                   for e, ranges in LARGE_SWINGS["ranges"].items()}
        case = {"id": f"steer_stand-{first + i:02d}", "kind": "steer_stand",
                "effects": effects, "seed": int(rng.integers(2 ** 31)),
                "draw_seed": seed, "viscous_c": round(float(rng.uniform(*BASE_VISCOUS)), 4),
                "angle_noise_rad": LARGE_SWINGS["angle_noise_rad"]}
        case["releases"] = [round(float(rng.uniform(*r)), 4) for r in LARGE_SWINGS["releases"]]
        out.append(case)
    return out


# ---- every concealed effect must show ------------------------------------------------------
# A concealed effect that changes the recording by less than the sensors' noise cannot be found
# by any method; a case holding one measures luck.  Each concealed effect must change the
# recorded signal (the one the diagnosis fits) by an RMS of at least VISIBLE sensor noise
# levels, sqrt(noise^2 + quantum^2 / 12), compared with the same case without it (same random
# stream, so the same hand, stamps and noise).  Two levels is the diagnosis's own detection limit
# (materiality: 4 noise variances).  A case that fails is redrawn from the same ranges with a
# random stream of its own (draw seed, case index, attempt), so no other case changes; the
# rejected draws and their visibilities are kept in the results.
VISIBLE = 2.0
SIGNAL = {"steer_stand": "steer_angle_rad", "shell_rock": "pipe_angle_rad", "ramp": "drive_rate_rad_s"}


def sensors(case: dict) -> dict:
    """The test bed's sensor settings for a case (its own angle noise where it has one)."""
    from roboball.testbed.physics import load_truth

    c = dict(load_truth()["sensors"])
    if "angle_noise_rad" in case:
        c["angle_noise_rad"] = case["angle_noise_rad"]
    return c


def noise_level(kind: str, case: dict | None = None) -> float:
    c = sensors(case or {})
    if SIGNAL[kind].endswith("_rad_s"):
        return math.hypot(c["rate_noise_rad_s"], c["rate_quantum_rad_s"] / math.sqrt(12.0))
    return math.hypot(c["angle_noise_rad"], c["angle_quantum_rad"] / math.sqrt(12.0))


def score(results: list) -> dict:
    rows = []
    for r in results:
        concealed = set(r["effects"])
        d = r.get("diagnosis")
        reported = set(m["effect"] for m in d["missing_physics"]) if d else {"<failed>"}
        errs = {}                   # effect -> relative errors of its parameters
        if d:
            for m in d["missing_physics"]:
                if m["effect"] in r["effects"]:
                    for p, truth in r["effects"][m["effect"]].items():
                        if p in m["parameters"] and truth != 0:
                            errs.setdefault(m["effect"], []).append(abs(m["parameters"][p] - truth) / abs(truth))
        drop = None
        if d and concealed:
            f = d["fit"]
            drop = 1.0 - f["rmse_heldout_after"] / f["rmse_heldout_before"]
        rows.append(dict(id=r["id"], kind=r["kind"], concealed=sorted(concealed), reported=sorted(reported),
                         immaterial=sorted(r.get("immaterial", [])),
                         exact=concealed == reported, param_errors=errs, drop=drop,
                         verdict=d["verdict"] if d else "failed", seconds=r.get("diagnose_s")))
    null = [x for x in rows if not x["concealed"]]
    nonnull = [x for x in rows if x["concealed"]]
    by_effect = {}
    for x in rows:
        for e, v in x["param_errors"].items():
            by_effect.setdefault(e, []).extend(v)
    errs = [e for v in by_effect.values() for e in v]
    drops = [x["drop"] for x in nonnull if x["drop"] is not None]
    return dict(
        rows=rows, n=len(rows),
        exact_set_accuracy=sum(x["exact"] for x in rows) / len(rows),
        null_false_positive_rate=(sum(bool(x["reported"]) for x in null) / len(null)) if null else None,
        median_parameter_error=statistics.median(errs) if errs else None,
        parameter_error_by_effect={e: (statistics.median(v), max(v), len(v)) for e, v in sorted(by_effect.items())},
        median_heldout_rmse_drop=statistics.median(drops) if drops else None,
        per_kind={k: sum(x["exact"] for x in rows if x["kind"] == k) / max(1, sum(x["kind"] == k for x in rows))
                  for k in SETS},
        immaterial=immaterial_tally(rows),
    )


def immaterial_tally(rows) -> dict:
    """How the candidates refused for materiality alone (supported by the data, too small to
    add) relate to the truth: concealed effects the diagnosis missed but saw, and effects it saw
    that were not concealed (the materiality rule's misses and its saves)."""
    true, false = [], []
    for x in rows:
        for e in x["immaterial"]:
            (true if e in x["concealed"] and e not in x["reported"] else false).append(f"{x['id']}:{e}")
    return dict(concealed=true, not_concealed=false)


def confusion(rows) -> str:
    names = sorted({e for x in rows for e in x["concealed"] + x["reported"]})
    labels = ["none"] + names
    m = {a: {b: 0 for b in labels} for a in labels}
    for x in rows:
        for a in (x["concealed"] or ["none"]):
            for b in (x["reported"] or ["none"]):
                m[a][b] += 1
    short = {n: n.replace("_friction", "").replace("_stiffness", "_k").replace("_resistance", "_res")[:11] for n in labels}
    corner = "concealed \\ reported"
    head = f"{corner:<22}" + "".join(f"{short[b]:>12}" for b in labels)
    lines = [head]
    for a in labels:
        lines.append(f"{a:<22}" + "".join(f"{m[a][b]:>12}" for b in labels))
    return "\n".join(lines)
