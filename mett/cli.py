"""The ``mett`` command line.

Bad arguments print one line on stderr and exit with status 2 (argparse's convention); a
``ValueError`` from the library is reported the same way, never as a traceback.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence

from . import presets
from .top import TippeTop

__all__ = ["main"]

_FIELDS = ("m", "R", "alpha", "I1", "I3", "mu", "g")


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, f"mett: error: {message}\n")


def _add_top_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--preset", default=None, help=f"one of: {', '.join(presets.names())}")
    for name in _FIELDS:
        p.add_argument(f"--{name}", type=float, default=None, help=f"override {name} (SI units)")


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


def _fmt(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:.6g}"


def _cmd_info(args: argparse.Namespace) -> int:
    top = _top_from_args(args)
    from .thresholds import lambda_E, lambda_roll

    rows = [
        ("m [kg]", _fmt(top.m)),
        ("R [m]", _fmt(top.R)),
        ("alpha", _fmt(top.alpha)),
        ("I1 [kg m^2]", _fmt(top.I1)),
        ("I3 [kg m^2]", _fmt(top.I3)),
        ("mu [s/m]", _fmt(top.mu)),
        ("g [m/s^2]", _fmt(top.g)),
        ("gamma = I1/I3", _fmt(top.gamma)),
        ("sigma = m R^2/I3", _fmt(top.sigma)),
        ("group", top.group),
        ("admissible (1-a < gamma < 1+a)", str(top.is_admissible)),
        ("rational METT", str(top.is_rational)),
        ("lambda_thres [kg m^3/s]", _fmt(top.lambda_thres)),
        ("lambda_0 [kg m^3/s]", _fmt(top.lambda_0)),
        ("lambda_E [kg m^3/s]", _fmt(lambda_E(top))),
        ("lambda_roll [kg m^3/s]", _fmt(lambda_roll(top))),
    ]
    c = math.cos(args.theta0)
    if c > top.alpha and math.isfinite(top.lambda_thres):
        lam_needed = max(top.lambda_thres, top.lambda_0)
        rows.append(
            (
                f"min omega3 to invert from theta0={args.theta0:g} [rad/s]",
                _fmt(lam_needed / (top.R * top.I3 * (c - top.alpha))),
            )
        )
    width = max(len(k) for k, _ in rows)
    for k, v in rows:
        print(f"{k:<{width}}  {v}")
    return 0


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mett", description="Tippe-top dynamics around the METT.")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    sub.required = True
    p = sub.add_parser("info", help="parameters, thresholds and group of a top")
    _add_top_arguments(p)
    p.add_argument("--theta0", type=float, default=0.1, help="start angle for the minimal spin")
    p.set_defaults(func=_cmd_info)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = _build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:
        print(f"mett: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
