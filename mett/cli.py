"""The ``mett`` command line.

Every error, whether a bad argument or a ``ValueError`` from the library, is one line on stderr
(``mett: error: ...``) and exit status 2 (argparse's convention), never a traceback; ``--traceback``
shows it for a bug report. Arguments, paths and options are checked before any computation or
write. Warnings are printed one line each (``mett: warning: ...``) after a successful command and
dropped when the command fails. Progress bars (tqdm, on stderr) are shown by default only when
stderr is a terminal, so logs never receive carriage-return animations.

Exit status (:data:`EXIT_STATUS`): 0 success; 1 ``mett simulate`` ran but its run did not complete
(status "failed" or "contact_lost": the partial results are printed and written as asked); 2 bad
input, a file that cannot be written, or nothing to print to (stdout closed); 70 an internal error
(a bug: rerun with ``--traceback``); 130 interrupted (Ctrl-C); 141 stdout is a closed pipe
(``mett info | head -1``: quietly, as other Unix tools). ``mett sweep`` exits 0 once its table is
written, whatever the statuses of its rows (they are data, counted in its summary).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import textwrap
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NoReturn

from . import __version__, presets
from .top import TippeTop

__all__ = ["EXIT_STATUS", "main"]

EXIT_STATUS = {
    0: "success",
    1: "mett simulate: the run did not complete (failed or contact_lost); partial results kept",
    2: "bad input or options, a file that cannot be written or read, stdout closed",
    70: "internal error (a bug: rerun with --traceback and report it)",
    130: "interrupted (Ctrl-C)",
    141: "stdout is a closed pipe (e.g. mett info | head -1)",
}
"""What each exit status of ``mett`` means (printed by ``mett --help``)."""
_INCOMPLETE, _USAGE, _INTERNAL, _INTERRUPTED, _BROKEN_PIPE = 1, 2, 70, 130, 141

_FIELDS = ("m", "R", "alpha", "I1", "I3", "mu", "g")
_UNITS = {"m": "kg", "R": "m", "alpha": "1", "I1": "kg m^2", "I3": "kg m^2", "mu": "s/m",
          "g": "m/s^2"}  # fmt: skip
# The Dask scheduler must answer within this (s) before the sweep gives up (--scheduler-timeout).
_SCHEDULER_TIMEOUT = 5.0


# A negative number as an option's value: argparse alone takes "-1e20" for an option.
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^-(inf|infinity|nan)$", re.I)


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = _NEGATIVE_NUMBER  # argparse's hook for "is a number"

    def error(self, message: str) -> NoReturn:  # one line, exit 2
        self.exit(2, f"mett: error: {_one_line(message)}\n")


class _Formatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows ``(default: X)`` for options that have a meaningful default (not None or False)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        if action.default is None or action.default is False or action.help is None:
            return action.help or ""
        return super()._get_help_string(action) or ""

    def _split_lines(self, text: str, width: int) -> list[str]:
        # argparse's own, without breaking at hyphens: a law's name (rolling-resistance:MU_R,MU)
        # stays whole in the help
        return textwrap.wrap(self._whitespace_matcher.sub(" ", text).strip(), width,
                             break_on_hyphens=False)  # fmt: skip


# --- argument types: checked by argparse, so a bad value is a one-line usage error -------------
# Numbers as written in C, Python or a shell script, in ASCII: float() alone also takes "1_000"
# and digits of other scripts ("١٥٥").
_FLOAT = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?|[+-]?(inf|infinity|nan)", re.I | re.A)
_INT = re.compile(r"[+-]?\d+", re.A)


def _real(text: str) -> float:
    if not _FLOAT.fullmatch(text.strip()):
        raise argparse.ArgumentTypeError(f"invalid float value: {text!r}")
    x = float(text)
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"must be a finite number; got {text!r}")
    return x


def _positive(text: str) -> float:
    x = _real(text)
    if x <= 0.0:
        raise argparse.ArgumentTypeError(f"must lie in (0, inf); got {text!r}")
    return x


def _rtol(text: str) -> float:
    from .dynamics.simulation import RTOL_MAX, RTOL_MIN  # the range simulate accepts

    x = _real(text)
    if not RTOL_MIN <= x <= RTOL_MAX:
        raise argparse.ArgumentTypeError(
            f"must lie in [{RTOL_MIN:.3g}, {RTOL_MAX:g}]; got {text!r}"
        )
    return x


def _theta(text: str) -> float:
    x = _real(text)
    if not 0.0 <= x <= math.pi:
        raise argparse.ArgumentTypeError(f"must lie in [0, pi]; got {text!r}")
    return x


def _workers(text: str) -> int:
    if not _INT.fullmatch(text.strip()):
        raise argparse.ArgumentTypeError(f"invalid int value: {text!r}")
    n = int(text)
    if not 1 <= n <= 4096:
        raise argparse.ArgumentTypeError(f"must lie in [1, 4096]; got {text!r}")
    return n


def _friction(text: str) -> Any:
    """``NAME:ARGS`` of a law of :data:`mett.friction.LAWS`, e.g. ``coulomb-contensou:0.3,5e-4``."""
    from .friction import LAWS

    forms = ", ".join(f"{f.spelled(n)} [{', '.join(f.units)}]" for n, f in LAWS.items())
    name, _, rest = text.strip().partition(":")
    form = LAWS.get(name.strip())
    values = [v.strip() for v in rest.split(",")] if rest.strip() else []
    if form is None or len(values) != len(form.args) or not all(map(_FLOAT.fullmatch, values)):
        raise argparse.ArgumentTypeError(f"invalid value {text!r}; give one of {forms}")
    try:
        return form.build(*map(float, values))
    except (TypeError, ValueError) as exc:  # the law's own range check, naming the argument
        raise argparse.ArgumentTypeError(f"{_one_line(str(exc))} in {text!r}") from None


def _stem(text: str) -> tuple[float, float]:
    """``RADIUS,DISTANCE`` (m) of :meth:`mett.TippeTop.with_stem`."""
    parts = text.split(",")
    if len(parts) != 2:
        raise argparse.ArgumentTypeError(f"give RADIUS,DISTANCE in m (two numbers); got {text!r}")
    try:
        radius, distance = (_positive(x) for x in parts)
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"RADIUS,DISTANCE (m): {exc}") from None
    return radius, distance


# --- paths: checked before any work, so nothing is computed that cannot be written -------------
def _check_output_file(option: str, path: str, suffixes: Sequence[str] | None = None) -> Path:
    p = Path(path)
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise ValueError(f"{option} must end in one of {', '.join(suffixes)}; got {path!r}")
    if p.is_dir():
        raise ValueError(f"{option} must be a file, not a directory; got {path!r}")
    parent = p.parent
    if not parent.is_dir():
        raise ValueError(f"{option}: the directory {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise ValueError(f"{option}: the directory {str(parent)!r} is not writable")
    if p.exists() and not os.access(p, os.W_OK):
        raise ValueError(f"{option}: {path!r} exists and is not writable")
    return p


def _check_output_dir(option: str, path: str) -> Path:
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{option} must be a directory; {path!r} is a file")
    existing = p
    while not existing.exists():  # the first existing ancestor must be a writable directory
        existing = existing.parent
    if not existing.is_dir():
        raise ValueError(f"{option}: {str(existing)!r} is a file, so {path!r} cannot be created")
    if not os.access(existing, os.W_OK):
        raise ValueError(f"{option}: {str(existing)!r} is not writable")
    return p


def _image_suffixes() -> tuple[str, ...]:
    from matplotlib.backend_bases import FigureCanvasBase

    return tuple(f".{ext}" for ext in FigureCanvasBase.get_supported_filetypes())


# --- output ------------------------------------------------------------------------------------
_TRAJ_SUFFIXES = (".csv", ".npz", ".nc")


def _need_xarray(option: str) -> None:
    """A NetCDF output needs xarray: refused before any work when it is missing."""
    try:
        import xarray  # noqa: F401
    except ImportError:
        raise ValueError(f"{option} .nc needs xarray: pip install 'mett[xarray]'") from None


def _fmt(x: float, digits: int = 6) -> str:
    return str(x) if not math.isfinite(x) else f"{x:.{digits}g}"


def _json_number(x: float) -> float | None:
    """A float for JSON; None (null) where it is infinite or undefined."""
    x = float(x)
    return x if math.isfinite(x) else None


def _print_rows(rows: Sequence[tuple[str, str]]) -> None:
    """``label  value`` lines with the values in one column."""
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")


def _finite_or_null(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _finite_or_null(v) for k, v in obj.items()}
    if isinstance(obj, float):
        return _json_number(obj)
    return obj


def _print_json(data: dict) -> None:
    """Strict JSON (no NaN/Infinity tokens): non-finite numbers become null."""
    print(json.dumps(_finite_or_null(data), indent=2, allow_nan=False))


def _progress_enabled(flag: bool | None) -> bool:
    """--progress / --no-progress, or by default: only on a terminal (no \\r in logs)."""
    if flag is not None:
        return flag
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty and isatty())


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


# --- the top and the state -----------------------------------------------------------------------
def _add_top_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--preset", default=None, help=f"one of: {', '.join(presets.names())}")
    for name in _FIELDS:
        p.add_argument(
            f"--{name}", type=_real, default=None, help=f"override {name} [{_UNITS[name]}]"
        )


def _top_from_args(args: argparse.Namespace) -> TippeTop:
    given = {k: getattr(args, k) for k in _FIELDS if getattr(args, k) is not None}
    if args.preset is not None:
        return presets.get(args.preset, **given)
    missing = [k for k in ("m", "R", "alpha", "I1", "I3") if k not in given]
    if missing:
        raise ValueError(
            f"without --preset give all of --m --R --alpha --I1 --I3 (missing {missing})"
        )
    return TippeTop(**given)


def _add_state_arguments(p: argparse.ArgumentParser, *, required: bool) -> None:
    p.add_argument("--theta0", type=_theta, required=required, default=None, help="θ(0) [rad]")
    p.add_argument("--omega3", type=_real, required=required, default=None, help="ω3(0) [rad/s]")
    p.add_argument("--thetadot", type=_real, default=0.0, help="θ̇(0) [rad/s]")
    p.add_argument("--phidot", type=_real, default=0.0, help="φ̇(0) [rad/s]")
    p.add_argument(
        "--cm-at-rest",
        action="store_true",
        help="start with the centre of mass at rest (the contact point gliding) instead of the "
        "contact point at rest",
    )


def _state_from_args(args: argparse.Namespace, top: TippeTop):
    from .state import State

    if args.cm_at_rest:
        return State.with_cm_at_rest(
            top, theta=args.theta0, omega3=args.omega3, thetadot=args.thetadot, phidot=args.phidot
        )
    return State(theta=args.theta0, omega3=args.omega3, thetadot=args.thetadot, phidot=args.phidot)


def _preset_stem(args: argparse.Namespace) -> tuple[float, float] | None:
    """(radius, distance) (m) of the stem of ``--preset`` (:func:`mett.presets.stemmed`), if it
    has one and no --model is given or the one given takes a stem; None otherwise."""
    from .dynamics import MODELS

    if args.preset is None:
        return None
    model = getattr(args, "model", None)  # mett predict has no --model
    if model is not None and not any(o.name == "stem_radius" for o in MODELS[model].options):
        return None
    try:
        top = presets.stemmed(args.preset)
    except ValueError:  # a preset without a stem
        return None
    return (top.radius, top.distance)


def _model_options(args: argparse.Namespace, top: TippeTop) -> tuple[str, dict[str, Any]]:
    """The model and the keyword arguments of :func:`mett.simulate` that --model, --friction and
    --stem give, or a ``ValueError`` saying what the model needs, before any run.

    Which laws a model runs with is the registry's (:func:`mett.dynamics.registry.check_friction`,
    whose message is kept); which models take a stem, those that declare ``stem_radius``.
    """
    from .dynamics import MODELS
    from .dynamics.registry import check_friction
    from .friction import LAWS

    name = args.model or ("stemmed" if args.stem is not None else "gliding")
    model = MODELS[name]
    law = args.friction
    if law is not None and args.mu is not None:
        raise ValueError("--mu is ignored with --friction (the law's mu replaces the top's); "
                         "leave --mu out")  # fmt: skip
    try:
        check_friction(model, law)
    except ValueError as exc:
        forms = " or ".join(f.spelled(n) for n, f in LAWS.items() if f.law in model.friction)
        if type(None) in model.friction:
            forms += " (or no --friction)"
        raise ValueError(f"--model {name} takes --friction {forms}: {exc}") from None
    options = {o.name: o for o in model.options}
    stemmed = [m.name for m in MODELS.values() if any(o.name == "stem_radius" for o in m.options)]
    kw: dict[str, Any] = {"model": name}
    if law is not None:
        kw["friction"] = law
    if "stem_radius" in options:
        if args.stem is None:
            doc = f"{options['stem_radius'].doc}; {options['stem_distance'].doc}"
            raise ValueError(f"--model {name} needs --stem RADIUS,DISTANCE ({doc})")
        top.with_stem(*args.stem)  # the stem's geometry, checked before any run
        kw["stem_radius"], kw["stem_distance"] = args.stem
    elif args.stem is not None:
        raise ValueError(f"--stem applies to --model {', '.join(stemmed)} only; got --model {name}")
    return name, kw


# --- commands ------------------------------------------------------------------------------------
def _cmd_info(args: argparse.Namespace) -> int:
    top = _top_from_args(args)
    from .thresholds import lambda_E, lambda_roll

    values: dict[str, Any] = {
        **{k: getattr(top, k) for k in _FIELDS},
        "gamma": top.gamma,
        "sigma": top.sigma,
        "group": top.group,
        "subgroup": top.subgroup,
        "admissible": bool(top.is_admissible),
        "rational": bool(top.is_rational),
        "lambda_thres": top.lambda_thres,
        "lambda_0": top.lambda_0,
        "lambda_E": float(lambda_E(top)),
        "lambda_roll": float(lambda_roll(top)),
    }
    c = math.cos(args.theta0)
    min_spin = None
    if c > top.alpha and math.isfinite(top.lambda_thres):
        lam_needed = max(top.lambda_thres, top.lambda_0)
        min_spin = lam_needed / (top.R * top.I3 * (c - top.alpha))
    if args.json:
        out = {k: (_json_number(v) if isinstance(v, float) else v) for k, v in values.items()}
        out["min_omega3_to_invert"] = {
            "theta0": args.theta0,
            "omega3": None if min_spin is None else _json_number(min_spin),
        }
        out["units"] = {**_UNITS, "lambda": "kg m^3/s", "omega3": "rad/s", "theta0": "rad"}
        _print_json(out)
        return 0
    rows = [(f"{k} [{_UNITS[k]}]" if _UNITS[k] != "1" else k, _fmt(values[k])) for k in _FIELDS]
    rows += [
        ("gamma = I1/I3", _fmt(top.gamma)),
        ("sigma = m R^2/I3", _fmt(top.sigma)),
        ("group", top.group),
        ("class (tumbling stability)", top.subgroup),
        ("admissible (1-a < gamma < 1+a)", str(top.is_admissible)),
        ("rational METT", str(top.is_rational)),
        ("lambda_thres [kg m^3/s]", _fmt(values["lambda_thres"])),
        ("lambda_0 [kg m^3/s]", _fmt(values["lambda_0"])),
        ("lambda_E [kg m^3/s]", _fmt(values["lambda_E"])),
        ("lambda_roll [kg m^3/s]", _fmt(values["lambda_roll"])),
    ]
    if min_spin is not None:
        rows.append((f"min omega3 to invert from theta0={args.theta0:g} [rad/s]", _fmt(min_spin)))
    _print_rows(rows)
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    # everything that can be checked is checked before the run
    out = None if args.out is None else _check_output_file("--out", args.out, _TRAJ_SUFFIXES)
    if out is not None and out.suffix.lower() == ".nc":
        _need_xarray("--out")
    plot = None if args.plot is None else _check_output_file("--plot", args.plot, _image_suffixes())
    top = _top_from_args(args)
    state = _state_from_args(args, top)
    if args.stem is None:  # a preset with a stem runs with it (mett.presets.stemmed)
        args.stem = _preset_stem(args)
    name, kw = _model_options(args, top)

    import numpy as np

    from .classification import asymptotic_state
    from .dynamics import simulate
    from .dynamics.stem import MODEL as STEMMED
    from .integrals import jellett

    run_top: Any = top
    if name == STEMMED.name:  # as mett.simulate(top.with_stem(r, d), ...): contact, touchdowns
        run_top = top.with_stem(kw.pop("stem_radius"), kw.pop("stem_distance"))
    traj = simulate(run_top, state, args.t_end, rtol=args.rtol, backend=args.backend,
                    stop_on_contact_loss=args.stop_on_contact_loss, **kw)  # fmt: skip
    written = []
    if out is not None:  # the partial run too (exit 1)
        from .dynamics import _export

        run = {"rtol": args.rtol, "t_end": args.t_end}  # where the trajectory does not record them
        if out.suffix.lower() == ".npz":
            traj.save(out)
        elif out.suffix.lower() == ".nc":
            _export.to_netcdf(_export.trajectory_to_xarray(traj, **run), out)
        else:
            _export.write_trajectory_csv(traj, out, **run)
        written.append(out)
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from .plotting import plot_theta

        fig = plot_theta(traj)
        fig.savefig(plot, dpi=110)
        plt.close(fig)
        written.append(plot)

    lam = float(jellett(top, state))
    cross = traj.crossings(np.pi / 2)
    pred, pred_error = None, None
    if lam > 0:
        try:
            pred = asymptotic_state(top, lam)
        except (ValueError, ArithmeticError, RuntimeError) as exc:  # the run's results stand
            pred_error = _one_line(str(exc))
    else:  # the end-state theory is for λ > 0 (a mirror image spins with −λ)
        pred_error = f"lambda = {lam:.6g} <= 0: the end-state prediction needs lambda > 0"
    status = 0 if traj.status == "completed" else _INCOMPLETE
    if args.json:
        _print_json(
            {
                "status": traj.status, "message": traj.message, "model": traj.model,
                "lambda": lam, "lambda_ratio": lam / top.lambda_thres,
                "t_invert": float(cross[0]) if cross.size else None,
                "t_end": traj.t_final, "theta_end": float(traj.theta[-1]),
                "omega3_end": float(traj.omega3[-1]),
                "predicted": None if pred is None else
                {"kind": pred.kind, "theta": float(pred.theta), "omega3": float(pred.omega3)},
                "prediction_error": pred_error,
                "wrote": [str(p) for p in written],
                "units": {"lambda": "kg m^3/s", "t": "s", "theta": "rad", "omega3": "rad/s"},
            }
        )  # fmt: skip
        return status
    rows = [
        ("status", traj.status + (f" ({traj.message})" if traj.message else "")),
        ("lambda / lambda_thres", _fmt(lam / top.lambda_thres)),
        ("first theta = pi/2 [s]", _fmt(cross[0]) if cross.size else "never (within t_end)"),
        ("theta(end) [rad]", f"{_fmt(traj.theta[-1])}  at t = {_fmt(traj.t[-1])} s"),
        ("omega3(end) [rad/s]", _fmt(traj.omega3[-1])),
    ]
    if pred is not None:
        rows.append(
            (
                "predicted end state",
                f"{pred.kind}: theta = {_fmt(pred.theta)}, omega3 = {_fmt(pred.omega3)}",
            )
        )
    elif pred_error is not None:
        rows.append(("predicted end state", f"unavailable ({pred_error})"))
    rows += [("wrote", str(p)) for p in written]
    _print_rows(rows)
    return status


def _cmd_period(args: argparse.Namespace) -> int:
    from . import integrals, separation

    given = [v is not None for v in (args.E, args.D, args.lam)]
    if any(given) and not all(given):
        raise ValueError("give all of --E --D --lam, or a state with --theta0 --omega3")
    has_state = args.theta0 is not None and args.omega3 is not None
    if not all(given) and not has_state:
        raise ValueError("give --E --D --lam, or a rolling state with --theta0 --omega3")
    top = _top_from_args(args)
    if all(given):
        E, D, lam, z0 = args.E, args.D, args.lam, None
    else:
        state = _state_from_args(args, top)
        # the METT's energy is the modified energy Ẽ (= E when the contact point is at rest,
        # not when the centre of mass is: --cm-at-rest)
        E, D, lam = (
            float(f(top, state))
            for f in (integrals.modified_energy, integrals.routh, integrals.jellett)
        )
        z0 = math.cos(args.theta0)
    band = separation.band(top, E, D, lam, z0=z0)
    if band.kind == "none":
        raise ValueError(f"no admissible motion: E lies {-band.depth:.3g} J below the minimum of V")
    T = float(separation.nutation_period(top, E, D, lam, z0=z0))
    prec = float(separation.mean_precession(top, E, D, lam, z0=z0))
    theta_min, theta_max = math.acos(band.z_high), math.acos(band.z_low)
    if args.json:
        _print_json(
            {
                "E_mod": E, "D": D, "lam": lam, "motion": band.kind,
                "z_low": band.z_low, "z_high": band.z_high,
                "theta_min": theta_min, "theta_max": theta_max,
                "nutation_period": _json_number(T), "mean_precession": _json_number(prec),
                "units": {"E_mod": "J", "D": "kg m^2/s", "lam": "kg m^3/s", "theta": "rad",
                          "nutation_period": "s", "mean_precession": "rad/s"},
            }
        )  # fmt: skip
        return 0
    _print_rows(
        [
            ("modified energy E~ [J]", repr(E)),
            ("Routh D [kg m^2/s]", repr(D)),
            ("Jellett lam [kg m^3/s]", repr(lam)),
            ("motion", band.kind),
            ("turning points z", f"{band.z_low:.10g}, {band.z_high:.10g}"),
            ("turning points theta [rad]", f"{theta_min:.10g}, {theta_max:.10g}"),
            ("nutation period [s]", _fmt(T, 10)),
            ("mean precession [rad/s]", _fmt(prec, 10)),
        ]
    )
    return 0


def _dpi(text: str) -> int:
    """--dpi: an integer from 10 to 2400 (dots per inch)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"must be an integer from 10 to 2400 (dots per inch); got {text!r}"
        ) from None
    if not 10 <= value <= 2400:
        raise argparse.ArgumentTypeError(
            f"must be an integer from 10 to 2400 (dots per inch); got {text!r}"
        )
    return value


def _cmd_figures(args: argparse.Namespace) -> int:
    out = _check_output_dir("--out", args.out)
    custom = args.preset is not None or any(getattr(args, k) is not None for k in _FIELDS)
    kw: dict[str, Any] = {}
    if custom:
        kw["top"] = _top_from_args(args)
    from . import gallery

    progress = _progress_enabled(False if args.quiet else args.progress)
    paths = gallery.generate(
        out, animation=not args.no_animation, progress=progress, dpi=args.dpi,
        format=args.format, **kw,
    )  # fmt: skip
    # under mett's own name: `--out .` must not replace a README.md of the user's
    index = out / gallery.INDEX_NAME
    left_out = gallery.skipped(kw.get("top"))
    index.write_text(gallery.index_markdown(paths, left_out=left_out), encoding="utf-8")
    _print_rows([("wrote", str(p)) for p in [*paths, index]])
    return 0


_GRID_FORMS = "START:STOP:NUM, log:START:STOP:NUM (START, STOP > 0) or a list V1,V2,..."
_MAX_AXIS = 1_000_000


def _grid_axis(name: str, values: str) -> Any:
    """The values of one ``--grid NAME=VALUES`` axis (see :data:`_GRID_FORMS`)."""
    import numpy as np

    def bad(why: str) -> ValueError:
        return ValueError(f"--grid {name}={values}: {why}; give {name}={_GRID_FORMS}")

    if name == "friction":  # the law's name per point (its coefficient: the top's mu)
        from .friction import LAW_NAMES

        laws = [v.strip() for v in values.split(",")]
        if not all(v in LAW_NAMES for v in laws):
            raise ValueError(f"--grid friction=... takes a list of {', '.join(LAW_NAMES)}; "
                             f"got {values!r}")  # fmt: skip
        return laws
    parts = [p.strip() for p in values.split(":")]
    log = parts[0].lower() == "log"
    if log:
        parts = parts[1:]
    if len(parts) == 1 and not log:  # a list (one value or more)
        items = [v.strip() for v in values.split(",")]
        if not all(_FLOAT.fullmatch(v) for v in items):
            raise bad("a list takes numbers")
        grid = np.array([float(v) for v in items])
        if not np.all(np.isfinite(grid)):
            raise bad("the values must be finite")
        if len(grid) > _MAX_AXIS:
            raise bad(f"at most {_MAX_AXIS} values")
        return grid
    if len(parts) != 3:
        raise bad("not one of the forms")
    if not (_FLOAT.fullmatch(parts[0]) and _FLOAT.fullmatch(parts[1]) and _INT.fullmatch(parts[2])):
        raise bad("START and STOP must be numbers and NUM an integer")
    start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
    if not (math.isfinite(start) and math.isfinite(stop)):
        raise bad("START and STOP must be finite")
    if not 1 <= num <= _MAX_AXIS:
        raise bad(f"NUM must lie in [1, {_MAX_AXIS}]")
    if log:
        if not (start > 0 and stop > 0):
            raise bad("log spacing needs START, STOP > 0")
        return np.geomspace(start, stop, num)
    return np.linspace(start, stop, num)


def _parse_grid(specs: list[str]) -> dict:
    """``--grid`` axes: ``NAME=START:STOP:NUM`` (linear, numpy.linspace), ``NAME=log:START:STOP:NUM``
    (geometric, numpy.geomspace) or ``NAME=V1,V2,...``; ``friction=viscous,coulomb`` names laws."""
    grid = {}
    for spec in specs:
        name, sep, values = spec.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ValueError(f"--grid takes NAME={_GRID_FORMS}; got {spec!r}")
        axis = _grid_axis(name, values.strip())
        if name in grid:
            raise ValueError(f"--grid {name!r} is given twice")
        grid[name] = axis
    return grid


def _cmd_sweep(args: argparse.Namespace) -> int:
    out = _check_output_file("--out", args.out)  # .nc: NetCDF; any other name: CSV
    if out.suffix.lower() == ".nc":
        _need_xarray("--out")
    if args.checkpoint is not None:
        ckpt = _check_output_file("--checkpoint", args.checkpoint)
        if ckpt.resolve() == out.resolve():
            raise ValueError("--checkpoint and --out must be different files")
    grid = _parse_grid(args.grid)
    # an option the grid overrides would be silently ignored
    overrides = {name: [name] for name in (*_FIELDS, "theta0", "omega3")}
    overrides["omega3"].append("lam_ratio")  # lam_ratio sets ω3 at every point
    overrides["I1"].append("gamma")  # gamma sets I1 = γ I3
    for option, axes in overrides.items():
        hit = [a for a in axes if a in grid]
        if getattr(args, option) is not None and hit:
            raise ValueError(
                f"--{option} is ignored when --grid varies {hit[0]} (it sets {option} at every "
                f"point); leave --{option} out"
            )
    top = _top_from_args(args)
    _, model_kw = _model_options(args, top)

    from .sweeps import sweep

    kw = dict(
        t_end=args.t_end, progress=_progress_enabled(args.progress), checkpoint=args.checkpoint,
        rtol=args.rtol, **model_kw,
    )  # fmt: skip
    for name in ("theta0", "omega3"):  # the library's defaults unless given
        if getattr(args, name) is not None:
            kw[name] = getattr(args, name)
    if args.backend != "auto":  # (as before otherwise: a checkpoint's signature is unchanged)
        kw["backend"] = args.backend
    if args.scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise ValueError("--scheduler needs Dask: pip install 'mett[dask]'") from None
        _probe_scheduler(args.scheduler, args.scheduler_timeout)
        try:
            client = Client(args.scheduler, timeout=args.scheduler_timeout)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise ValueError(
                f"cannot reach the Dask scheduler at {args.scheduler!r} within "
                f"{args.scheduler_timeout:g} s ({_one_line(str(exc)) or type(exc).__name__})"
            ) from None
        with client:
            table = sweep(top, grid, executor=client.get_executor(), **kw)
    elif args.workers > 1:
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            table = sweep(top, grid, executor=pool, **kw)
    else:
        table = sweep(top, grid, **kw)
    from .dynamics import _export

    if out.suffix.lower() == ".nc":
        _export.to_netcdf(table.to_xarray(), out)
    else:
        _export.write_sweep_csv(table, out)
    counts = table["simulated"].value_counts().to_dict()
    _print_rows(
        [
            ("wrote", f"{out} ({len(table)} runs)"),
            ("end states", ", ".join(f"{k}: {v}" for k, v in counts.items())),
            ("agree with the prediction", str(int(table["agree"].sum()))),
        ]
    )
    return 0


def _probe_scheduler(address: str, timeout: float) -> None:
    """Fail at once when nothing listens at a TCP scheduler address (Dask would retry until its
    timeout); other protocols are left to Dask."""
    import socket
    from urllib.parse import urlsplit

    if "://" not in address:
        address = f"tcp://{address}"
    parts = urlsplit(address)
    if parts.scheme != "tcp":
        return
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        raise ValueError(f"--scheduler: invalid address {address!r}") from None
    if not host or port is None:
        raise ValueError(f"--scheduler needs an address like tcp://HOST:PORT; got {address!r}")
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except OSError as exc:
        raise ValueError(
            f"cannot reach the Dask scheduler at {address!r}: {exc.strerror or exc}"
        ) from None


# --- mett predict (mett.predict_inversion) ---------------------------------------------------------
def _cmd_predict(args: argparse.Namespace) -> int:
    top = _top_from_args(args)
    state = _state_from_args(args, top)
    from .inversion import predict_inversion

    p = predict_inversion(top, state, args.friction, method=args.method, tol=args.tol,
                          hops=args.hops, start=args.start)  # fmt: skip
    v = p.validity
    notes = list(v.notes)
    stem = _preset_stem(args)
    if stem is not None:
        # mett simulate runs such a preset with its stem; the reduction knows one contact only
        # (predict_inversion refuses a StemmedTop), so say what the answer covers
        notes.append(
            f"--preset {args.preset} has a stem (radius {stem[0]:g} m, {stem[1]:g} m from the "
            "ball's centre): this predicts its ball alone; after the stem touches down, beyond "
            "pi/2, the stem contact is outside the reduction"
        )
    values = {
        "method": p.method,
        "inverts": p.inverts,
        "reason": p.reason,
        "t_start": p.t_start,
        "t_half": p.t_half,
        "t_inv": p.t_inv,
        "tol": p.tol,
        "t_lift": p.t_lift,
        "epsilon": v.epsilon,
        "lambda_over_lambda_thres": v.spin_ratio,
        "outside_verified_range": v.outside_verified_range,
        "notes": notes,
    }
    if args.json:
        out: dict[str, Any] = {
            k: (_json_number(x) if isinstance(x, float) else x) for k, x in values.items()
        }
        out["units"] = {"t_start": "s", "t_half": "s", "t_inv": "s", "tol": "rad", "t_lift": "s"}
        _print_json(out)
        return 0
    rows = [
        ("method", p.method),
        ("inverts", str(p.inverts)),
        ("reason", p.reason),
        ("t_start [s]", _fmt(p.t_start)),
        ("t_half (mean theta passes pi/2) [s]", _fmt(p.t_half)),
        (f"t_inv (within {p.tol:g} rad of the end) [s]", _fmt(p.t_inv)),
        ("t_lift (nutation lifts it off before pi/2) [s]", _fmt(p.t_lift)),
        ("epsilon = T_nutation/t_half", _fmt(v.epsilon)),
        (
            "outside verified range",
            str(v.outside_verified_range) + (f" ({'; '.join(notes)})" if notes else ""),
        ),
    ]
    _print_rows(rows)
    return 0


# --- the parser ----------------------------------------------------------------------------------
def _cmd_warmup(args: argparse.Namespace) -> int:
    """Build the default models' machine code ahead of the first run, one line per task."""
    from .dynamics.taylor import cache_dir
    from .dynamics.warmup import WARMUP_DEFAULT, WARMUP_MODELS, warmup

    models = WARMUP_MODELS if args.all else tuple(args.model or WARMUP_DEFAULT)
    print(f"mett warmup: building {', '.join(models)} at rtol {args.rtol:g} "
          f"(Taylor kernels cached in {cache_dir()})", flush=True)  # fmt: skip
    done = warmup(models, rtol=args.rtol, progress=lambda line: print(line, flush=True))
    print(f"mett warmup: done, {len(done)} tasks in {sum(s for *_, s in done):.1f} s")
    return 0


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="mett",
        description="Tippe-top dynamics around the METT.",
        formatter_class=_Formatter,
        epilog="exit status: " + "; ".join(f"{k} {v}" for k, v in EXIT_STATUS.items()),
    )
    parser.add_argument("--version", action="version", version=f"mett {__version__}")
    parser.add_argument(
        "--traceback", action="store_true", help="show the full traceback of an error"
    )
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, metavar="COMMAND")
    sub.required = True

    def add(name: str, help: str, func: Callable) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help, description=help, formatter_class=_Formatter)
        p.set_defaults(func=func)
        return p

    json_help = "print JSON (SI units; null where a value is infinite or undefined)"
    model_help = (
        "the dynamical model (see mett.simulate); a model that needs a friction law or a stem is "
        "refused without it, saying which (default: gliding, or stemmed with --stem)"
    )
    from .friction import LAWS

    friction_help = (
        "the contact's friction law (default: viscous with the top's mu): one of "
        + ", ".join(f"{f.spelled(n)} [{', '.join(f.units)}]" for n, f in LAWS.items())
        + "; a law other than viscous runs the model made for it (e.g. coulomb: the dry-friction model)"
    )
    stem_help = (
        "a stem (mett.TippeTop.with_stem): its sphere's radius and the distance from the ball's "
        "centre to the stem sphere's centre [m]"
    )
    progress_help = "progress bar on stderr (default: only when stderr is a terminal)"

    p = add("info", "parameters, thresholds and group of a top", _cmd_info)
    _add_top_arguments(p)
    p.add_argument("--theta0", type=_theta, default=0.1, help="start angle for the minimal spin")
    p.add_argument("--json", action="store_true", help=json_help)

    from .dynamics import MODELS
    from .dynamics.simulation import BACKENDS

    backend_help = (
        "integrator: auto (the fastest exact one: taylor where the law is analytic, the "
        "compiled DOP853 for Coulomb friction), compiled, scipy, or taylor (Taylor series; "
        "sweeps run four points at a time on it, the fastest way through a grid)"
    )

    def add_run_options(p: argparse.ArgumentParser) -> None:
        """The options of a run that simulate and sweep share: model, law, stem, rtol, backend."""
        p.add_argument("--model", default=None, choices=sorted(MODELS), help=model_help)
        p.add_argument("--friction", type=_friction, default=None, metavar="LAW:ARGS",
                       help=friction_help)  # fmt: skip
        p.add_argument(
            "--stem", type=_stem, default=None, metavar="RADIUS,DISTANCE", help=stem_help
        )
        p.add_argument(
            "--rtol",
            type=_rtol,
            default=1e-10,
            help="relative tolerance, in [100 machine epsilons, 1e-2]",
        )
        p.add_argument("--backend", default="auto", choices=BACKENDS, help=backend_help)

    p = add("simulate", "simulate a top; print the inversion time and end state", _cmd_simulate)
    _add_top_arguments(p)
    _add_state_arguments(p, required=True)
    p.add_argument("--t-end", type=_positive, required=True, help="simulated time [s]")
    add_run_options(p)
    p.add_argument(
        "--out",
        default=None,
        help="write the trajectory (also when the run does not complete: exit 1): .npz "
        "(everything, for mett.load), .csv (the series with units, a # header of the run's "
        "settings) or .nc (NetCDF with units and settings; needs mett[xarray])",
    )
    p.add_argument("--plot", default=None, help="write θ(t) as an image (e.g. theta.png)")
    p.add_argument(
        "--stop-on-contact-loss",
        action="store_true",
        help="end the run where the normal force reaches 0 (status contact_lost) instead of "
        "following the ball top's flight and landing",
    )
    p.add_argument("--json", action="store_true", help=json_help)

    p = add("period", "turning points, nutation period and precession (rolling)", _cmd_period)
    _add_top_arguments(p)
    p.add_argument("--E", type=_real, default=None, help="modified energy Ẽ [J] (= E when ν = 0)")
    p.add_argument("--D", type=_real, default=None, help="Routh integral [kg m^2/s]")
    p.add_argument("--lam", type=_real, default=None, help="Jellett integral [kg m^3/s]")
    _add_state_arguments(p, required=False)
    p.add_argument("--json", action="store_true", help=json_help)

    p = add("sweep", "simulate a grid of parameters; write a CSV table", _cmd_sweep)
    _add_top_arguments(p)
    p.add_argument(
        "--grid", action="append", required=True, metavar="NAME=VALUES",
        help="a swept parameter (repeat for more): a TippeTop field, an initial condition, "
        "gamma, lam_ratio, contensou_radius or friction (a list of law names); VALUES: "
        "START:STOP:NUM (linear), log:START:STOP:NUM (geometric) or V1,V2,... An option the "
        "grid sets (e.g. --mu with a mu axis, --friction LAW:ARGS, which fixes mu) is refused",
    )  # fmt: skip
    p.add_argument("--t-end", type=_positive, required=True, help="simulated time per run [s]")
    p.add_argument("--theta0", type=_theta, default=None, help="θ(0) [rad] (default: 0.1)")
    p.add_argument(
        "--omega3", type=_real, default=None,
        help="ω3(0) [rad/s] (default: 155; not with a lam_ratio grid, which sets it)",
    )  # fmt: skip
    add_run_options(p)
    p.add_argument("--out", default="sweep.csv",
                   help="output table: .csv (a # header of the sweep's settings and units) or .nc "
                   "(NetCDF over the grid axes; needs mett[xarray])")  # fmt: skip
    p.add_argument("--workers", type=_workers, default=1, help="processes on this machine")
    p.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    p.add_argument(
        "--scheduler-timeout",
        type=_positive,
        default=_SCHEDULER_TIMEOUT,
        help="seconds to wait for the Dask scheduler",
    )
    p.add_argument("--checkpoint", default=None, help="JSON-lines checkpoint to resume from")
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help=progress_help
    )

    p = add("figures", "regenerate every published figure (of the thesis top or another)",
            _cmd_figures)  # fmt: skip
    _add_top_arguments(p)
    p.add_argument(
        "--out", default="figures",
        help="output directory: the PNGs, the GIF and an index mett-figures.md (mett's own file "
        "names only; nothing else there is touched)",
    )  # fmt: skip
    p.add_argument(
        "--format", default="png", choices=("png", "pdf", "svg"),
        help="file format of the figures: png (default), or pdf / svg (vector, for print)",
    )  # fmt: skip
    p.add_argument(
        "--dpi", type=_dpi, default=110,
        help="resolution in dots per inch, 10 to 2400 (default 110; 300 for print)",
    )  # fmt: skip
    p.add_argument("--no-animation", action="store_true", help="skip the GIF")
    p.add_argument(
        "--progress", action=argparse.BooleanOptionalAction, default=None, help=progress_help
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar (as --no-progress)")
    # mett warmup: the machine code of the default models, built ahead of the first run
    from .dynamics.warmup import WARMUP_DEFAULT, WARMUP_MODELS

    p = add("warmup", "compile the default models' machine code ahead of their first run",
            _cmd_warmup)  # fmt: skip
    p.add_argument(
        "--model", action="append", choices=WARMUP_MODELS, default=None,
        help=f"a model to build (repeat for more; default: {', '.join(WARMUP_DEFAULT)})",
    )  # fmt: skip
    p.add_argument("--all", action="store_true", help="build every model of --model's list")
    p.add_argument("--rtol", type=_rtol, default=1e-10,
                   help="the tolerance whose Taylor order is built (kernels are per order)")  # fmt: skip
    # mett predict: the inversion-time prediction (mett.predict_inversion)
    p = add("predict", "predict whether and when a top inverts, without simulating", _cmd_predict)
    _add_top_arguments(p)
    _add_state_arguments(p, required=True)
    p.add_argument("--friction", type=_friction, default=None, metavar="LAW:ARGS",
                   help=friction_help)  # fmt: skip
    p.add_argument("--tol", type=_positive, default=0.05,
                   help="t_inv: mean theta within this of its end state [rad], in (0, 0.5)")  # fmt: skip
    from .inversion import METHODS, STARTS

    p.add_argument("--method", default="gyroscopic", choices=METHODS,
                   help="the reduction: gyroscopic balance (default, verified) or the averaged "
                        "METT flow (seconds, flagged unverified); docs: theory/inversion")  # fmt: skip
    p.add_argument("--start", default="auto", choices=STARTS,
                   help="auto (default): a large tilt's start resolved by a short run of the full "
                        "model (accurate; 3-25 ms more, growing with omega3); linear: the linear "
                        "mode split always (~1 ms, bounded cost)")  # fmt: skip
    p.add_argument("--hops", action=argparse.BooleanOptionalAction, default=True,
                   help="follow the hopping top after a predicted lift-off (0.1-1 s more where "
                        "it hops); --no-hops: the gliding flow throughout")  # fmt: skip
    p.add_argument("--json", action="store_true", help=json_help)
    return parser


def _error(exc: BaseException) -> str:
    if isinstance(exc, ArithmeticError):
        return (
            f"numerical failure ({type(exc).__name__}: {_one_line(str(exc))}); the input is "
            "probably outside the range this computation handles"
        )
    if isinstance(exc, OSError):
        where = f" {exc.filename!r}" if getattr(exc, "filename", None) else ""
        return f"cannot write or read{where}: {exc.strerror or _one_line(str(exc))}"
    return _one_line(str(exc)) or type(exc).__name__


def _quiet_stdout() -> None:
    """Point stdout at /dev/null: its reader is gone, and the interpreter's own flush at exit
    must not print a second error."""
    try:
        fd = sys.stdout.fileno()
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, fd)
        os.close(devnull)
    except (AttributeError, OSError, ValueError):  # not a real file (a test's capture)
        pass


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``mett`` command with ``argv`` (default: ``sys.argv[1:]``); return the exit status.

    Usage errors raise ``SystemExit(2)`` from argparse (``--help`` and ``--version``:
    ``SystemExit(0)``); errors found while running return 2 after one line on stderr. The other
    statuses are in :data:`EXIT_STATUS`.
    """
    import numpy as np

    parser = _build_parser()
    args = parser.parse_args(argv)
    if sys.stdout is None:  # started with stdout closed (`mett info >&-`): results would be lost
        print("mett: error: standard output is closed; nothing could be printed", file=sys.stderr)
        return _USAGE
    with warnings.catch_warnings(record=True) as caught:
        if not sys.warnoptions:  # python -W ... decides for itself
            warnings.simplefilter("default")
        try:
            status = args.func(args)
            sys.stdout.flush()  # a closed pipe shows here, not at the interpreter's exit
        except KeyboardInterrupt:
            print("mett: interrupted", file=sys.stderr)
            return _INTERRUPTED
        except BrokenPipeError:  # the reader of stdout is gone (`| head -1`): quietly
            _quiet_stdout()
            return _BROKEN_PIPE
        except (
            ValueError,
            TypeError,
            ArithmeticError,
            OSError,
            np.linalg.LinAlgError,
        ) as exc:
            if args.traceback:
                raise
            print(f"mett: error: {_error(exc)}", file=sys.stderr)
            return _USAGE
        except Exception as exc:  # a bug: still one line, with a hint for the report
            if args.traceback:
                raise
            print(
                f"mett: internal error ({type(exc).__name__}: {_one_line(str(exc))}); "
                "rerun with --traceback and report it",
                file=sys.stderr,
            )
            return _INTERNAL
    for w in caught:
        print(f"mett: warning: {_one_line(str(w.message))}", file=sys.stderr)
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
