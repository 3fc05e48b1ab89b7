"""`roboball` command line.

Every subcommand turns user errors (RoboballError) into one line on stderr and a non-zero
exit code; a traceback means a bug in roboball, not in the user's input.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from roboball.errors import RoboballError
from roboball.kinds import CONTACT_MODELS, SIMULATED

FRICTION_CHOICES = ("none", "viscous", "coulomb_viscous", "majd")


class OneLineArgumentParser(argparse.ArgumentParser):
    """argparse, but a usage mistake is reported like every other user error: one line
    naming the problem and where to look, exit code 2 (no multi-line usage dump)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {' '.join(message.split())}; see '{self.prog} --help'\n")


def _positive(name):
    def conv(text):
        try:
            x = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got '{text}'")
        if not x > 0:
            raise argparse.ArgumentTypeError(f"{name} must be positive, got {text}")
        return x
    return conv


def _number(name):
    def conv(text):
        try:
            return float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got '{text}'")
    return conv


def _fill_from_table(args, path: Path, path_flag: str, reader, dests: tuple, needs: str, table: str) -> None:
    """Fill the flags `dests` that were not given with reader(path, pressure), the values at the
    pressure from a table the pipeline writes (`make figures`); a one-line error naming the flags
    (`needs`) when there is no table, naming its expected form (`table`) when it is not one."""
    if not path.is_file():
        raise RoboballError(f"contact '{args.contact}' needs {needs} at {args.pressure_kpa:g} kPa: give them, or run "
                            f"`make figures` to write {path} (or point {path_flag} at it)")
    try:
        values = reader(str(path), args.pressure_kpa)
    except (KeyError, ValueError) as exc:
        raise RoboballError(f"{path}: not a {table}: {exc}") from None
    for dest, value in zip(dests, values):
        if getattr(args, dest) is None:
            setattr(args, dest, value)


def _shell_from_regression(args) -> None:
    """Fill in the shell's --zeta and --omega-n at the pressure from the pipeline's regression
    when the contact model needs them and they were not given, and say so."""
    needs = args.contact in ("injected", "hydroelastic") and (args.zeta is None or args.omega_n is None) \
        and not (args.contact == "hydroelastic" and args.hydro_dissipation is not None)
    if not needs or args.pressure_kpa is None:
        return
    from roboball.pipeline.simulation import shell_at

    _fill_from_table(args, args.regression, "--regression", shell_at, ("zeta", "omega_n"),
                     "the shell's --zeta and --omega-n",
                     "shell regression table (columns name, value; rows zeta_a, zeta_b, omega_n_c, omega_n_d)")
    print(f"shell at {args.pressure_kpa:g} kPa: zeta {args.zeta:.4g}, omega_n {args.omega_n:.4g} rad/s "
          f"(from the pipeline's regression, {args.regression})")


def _shell_from_calibration(args) -> None:
    """For `--contact hydro_tuned`: Drake's hydroelastic contact with the modulus and dissipation
    of the pipeline's calibration (Fig. S3) at the pressure, each unless given, and say so."""
    if args.contact != "hydro_tuned":
        return
    if args.pressure_kpa is None:
        raise RoboballError("contact 'hydro_tuned' needs --pressure-kpa (the calibration is per pressure, kPa)")
    if args.hydro_modulus is None or args.hydro_dissipation is None:
        from roboball.pipeline.simulation import tuned_at

        _fill_from_table(args, args.hydro_fit, "--hydro-fit", tuned_at, ("hydro_modulus", "hydro_dissipation"),
                         "the calibrated --hydro-modulus and --hydro-dissipation",
                         "hydroelastic calibration table (columns pressure_kpa, hydro_modulus_pa, hydro_dissipation_s_m)")
        print(f"tuned hydroelastic shell at {args.pressure_kpa:g} kPa: modulus {args.hydro_modulus:.4g} Pa, "
              f"dissipation {args.hydro_dissipation:.4g} s/m (from the pipeline's calibration, {args.hydro_fit})")
    args.contact = "hydroelastic"    # Drake's contact; the calibration only chose its two numbers


def cmd_simulate(args) -> int:
    from roboball.checks import load_checked_robot
    from roboball.config import ROBOT_YAML
    from roboball.ingest.recording import write_recording
    from roboball.sim.scenarios import simulate
    from roboball.sim.spec import ShellParams, SimSpec

    if args.dt > 0.01:
        raise RoboballError(f"--dt {args.dt}: time step above 10 ms is not allowed (contact and friction become inaccurate)")
    if args.kind in ("shell_rock", "ramp") and args.pressure_kpa is None:
        # the recording says its shell pressure, whatever the contact model makes of it
        raise RoboballError(f"--pressure-kpa is required for {args.kind} (the shell's gauge pressure, kPa)")
    if args.pressure_kpa is not None and not (0 < args.pressure_kpa <= 500):
        raise RoboballError(f"--pressure-kpa {args.pressure_kpa}: must be in (0, 500] kPa gauge")
    if abs(args.release) > math.pi:
        raise RoboballError(f"--release {args.release:g}: beyond pi rad, looks like degrees; give the angle in radians")
    if args.sample_rate_hz * args.dt > 1.0 + 1e-9:
        raise RoboballError(f"--sample-rate-hz {args.sample_rate_hz:g}: faster than the time step ({1 / args.dt:g} Hz "
                            f"at --dt {args.dt:g}); lower the rate or the step")
    robot = load_checked_robot(ROBOT_YAML)   # schema + physics, before anything runs
    model = args.contact
    _shell_from_calibration(args)
    _shell_from_regression(args)
    shell = ShellParams(zeta=args.zeta, omega_n=args.omega_n, hydro_modulus=args.hydro_modulus,
                        hydro_dissipation=args.hydro_dissipation)
    friction = {"steer": args.friction_steer or args.friction, "drive": args.friction_drive or args.friction}
    spec = SimSpec(kind=args.kind, contact=args.contact, friction=friction, pressure_kpa=args.pressure_kpa,
                   shell=shell, dt=args.dt, robot=robot)
    print(f"simulating {args.duration:g} s of {args.kind} (contact {model}, time step {args.dt:g} s) ...",
          flush=True)
    try:
        df = simulate(spec, args.release, args.duration, sample_rate_hz=args.sample_rate_hz,
                      max_wall_s=args.max_wall_s)
    except ValueError as exc:
        raise RoboballError(str(exc))
    meta = {"kind": args.kind, "pressure_kpa": args.pressure_kpa, "source": "simulation",
            "simulation": {"contact": model, "friction": friction, "dt_s": args.dt,
                           "release": args.release, "zeta": args.zeta, "omega_n_rad_s": args.omega_n,
                           "hydro_modulus_pa": args.hydro_modulus, "hydro_dissipation_s_m": args.hydro_dissipation}}
    if args.kind == "ramp":
        meta["ramp_angle_deg"] = robot.ramp_angle_deg
    write_recording(args.out, df, meta)
    print(f"wrote {args.out} ({len(df)} samples, {args.duration:g} s of {args.kind}, contact {model})")
    return 0


def cmd_check_config(args) -> int:
    from roboball.checks import check_config_dir
    from roboball.config import CONFIG_DIR

    for path in check_config_dir(args.config_dir or CONFIG_DIR):
        print(f"ok {path}")
    return 0


def cmd_urdf(args) -> int:
    from roboball.atomic import write_text_atomic
    from roboball.config import load_robot
    from roboball.sim.urdf import make_urdf

    text = make_urdf(load_robot(args.robot))
    if args.out:
        write_text_atomic(args.out, text)
    else:
        sys.stdout.write(text)
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = OneLineArgumentParser(prog="roboball", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("simulate", help="simulate one experiment in Drake and write a recording")
    s.add_argument("kind", choices=SIMULATED, help="the experiment to simulate")
    s.add_argument("--contact", choices=CONTACT_MODELS, default="point",
                   help="shell-ground contact model: the paper's three, or hydro_tuned, Drake's hydroelastic contact "
                        "with the calibrated modulus and dissipation (default: point, the rigid shell)")
    s.add_argument("--friction", choices=FRICTION_CHOICES, default="none",
                   help="friction law on both joints, Table I values (default: none)")
    s.add_argument("--friction-steer", choices=FRICTION_CHOICES, help="override the steer joint's law (default: --friction)")
    s.add_argument("--friction-drive", choices=FRICTION_CHOICES, help="override the drive joint's law (default: --friction)")
    s.add_argument("--pressure-kpa", type=_number("--pressure-kpa"), metavar="KPA",
                   help="shell gauge pressure (kPa); required for shell_rock and ramp (default: none)")
    s.add_argument("--zeta", type=_positive("--zeta"), metavar="RATIO",
                   help="shell damping ratio at the pressure (dimensionless; default: from --regression)")
    s.add_argument("--omega-n", type=_positive("--omega-n"), metavar="RAD_S",
                   help="shell natural frequency at the pressure (rad/s; default: from --regression)")
    s.add_argument("--regression", type=Path, default=Path("results/identify/shell_regression.csv"), metavar="CSV",
                   help="the pipeline's shell regression, where injected and hydroelastic contact take --zeta and "
                        "--omega-n from when not given (default: %(default)s)")
    s.add_argument("--hydro-modulus", type=_positive("--hydro-modulus"), metavar="PA",
                   help="override eq. 10's hydroelastic modulus (Pa; default: eq. 10 at the pressure)")
    s.add_argument("--hydro-dissipation", type=_positive("--hydro-dissipation"), metavar="S_M",
                   help="override eq. 11's Hunt-Crossley dissipation (s/m; default: eq. 11 at the pressure)")
    s.add_argument("--hydro-fit", type=Path, default=Path("results/identify/hydro_tuned.csv"), metavar="CSV",
                   help="the pipeline's hydroelastic calibration, where hydro_tuned contact takes its modulus and "
                        "dissipation from when not given (default: %(default)s)")
    s.add_argument("--release", type=_number("--release"), default=0.05, metavar="RAD",
                   help="initial angle of the main coordinate, released from rest (rad; default: %(default)s)")
    s.add_argument("--duration", type=_positive("--duration"), default=10.0, metavar="S",
                   help="simulated time (s; default: %(default)s)")
    s.add_argument("--dt", type=_positive("--dt"), default=1e-3, metavar="S",
                   help="time step of the discrete plant (s, at most 0.01; default: %(default)s)")
    s.add_argument("--sample-rate-hz", type=_positive("--sample-rate-hz"), default=100.0, metavar="HZ",
                   help="rate of the written recording (Hz; default: %(default)s)")
    s.add_argument("--max-wall-s", type=_positive("--max-wall-s"), default=None, metavar="S",
                   help="give up (stuck integrator) after this much wall time (s; default: $ROBOBALL_SIM_MAX_WALL_S or none)")
    s.add_argument("--out", required=True, type=Path, metavar="CSV",
                   help="recording to write (CSV, with its JSON sidecar beside it)")
    s.set_defaults(func=cmd_simulate)

    c = sub.add_parser("check-config", help="validate configs/*.yaml against their schemas and the robot's physics")
    c.add_argument("--config-dir", type=Path, default=None, help="default: $ROBOBALL_CONFIG_DIR or the repo's configs/")
    c.set_defaults(func=cmd_check_config)

    u = sub.add_parser("urdf", help="print (or write) the URDF generated from configs/robot.yaml")
    u.add_argument("--robot", default=None, help="robot facts YAML (default: configs/robot.yaml)")
    u.add_argument("--out", type=Path, help="URDF file to write (default: print it)")
    u.set_defaults(func=cmd_urdf)

    for register in _EXTRA_COMMANDS:
        register(sub)
    return p


_EXTRA_COMMANDS = []


def register_command(fn):
    """Other modules add subcommands through this hook (imported in main)."""
    _EXTRA_COMMANDS.append(fn)
    return fn


def _load_plugins():
    import importlib
    for mod in ("roboball.cli.diagnose", "roboball.cli.design", "roboball.cli.stage", "roboball.cli.report",
                "roboball.cli.manifest"):
        try:
            importlib.import_module(mod)
        except ModuleNotFoundError as exc:
            if not (exc.name and mod.startswith(exc.name)):
                raise


def main(argv=None) -> int:
    _load_plugins()
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except RoboballError as exc:
        print(f"roboball: error: {exc}", file=sys.stderr)
        return exc.exit_code
    except OSError as exc:
        # A missing or unreadable input/output file named on the command line is the user's to
        # fix; OSErrors that name no file are bugs and keep their traceback.
        if exc.filename is None:
            raise
        print(f"roboball: error: {exc.filename}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("roboball: interrupted", file=sys.stderr)
        return 130

