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


def _state_from_args(args: argparse.Namespace, top: TippeTop):
    from .state import State

    if args.cm_at_rest:
        return State.with_cm_at_rest(
            top, theta=args.theta0, omega3=args.omega3, thetadot=args.thetadot, phidot=args.phidot
        )
    return State(theta=args.theta0, omega3=args.omega3, thetadot=args.thetadot, phidot=args.phidot)


def _cmd_simulate(args: argparse.Namespace) -> int:
    import numpy as np

    from .dynamics import simulate
    from .integrals import jellett
    from .thresholds import asymptotic_state

    top = _top_from_args(args)
    state = _state_from_args(args, top)
    if args.out is not None and not args.out.endswith((".csv", ".npz")):
        raise ValueError(f"--out must end in .csv or .npz; got {args.out!r}")
    traj = simulate(top, state, args.t_end, model=args.model, rtol=args.rtol)
    lam = float(jellett(top, state))
    cross = traj.crossings(np.pi / 2)
    print(f"status                 {traj.status}" + (f" ({traj.message})" if traj.message else ""))
    print(f"lambda / lambda_thres  {lam / top.lambda_thres:.6g}")
    t_inv = f"{cross[0]:.6g}" if cross.size else "never (within t_end)"
    print(f"first theta = pi/2 [s] {t_inv}")
    print(f"theta(end) [rad]       {traj.theta[-1]:.6g}  at t = {traj.t[-1]:.6g} s")
    print(f"omega3(end) [rad/s]    {traj.omega3[-1]:.6g}")
    if lam > 0:
        pred = asymptotic_state(top, lam)
        print(
            f"predicted end state    {pred.kind}: theta = {pred.theta:.6g}, omega3 = {pred.omega3:.6g}"
        )
    if args.out is not None:
        data = traj.as_dict()
        if args.out.endswith(".npz"):
            np.savez(args.out, **data)
        else:
            names = list(data)
            np.savetxt(args.out, np.column_stack([data[n] for n in names]), delimiter=",",
                       header=",".join(names), comments="")  # fmt: skip
        print(f"wrote {args.out}")
    if args.plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        from .plotting import plot_theta

        plot_theta(traj).savefig(args.plot, dpi=110)
        print(f"wrote {args.plot}")
    return 0


def _cmd_period(args: argparse.Namespace) -> int:
    from . import integrals, separation

    top = _top_from_args(args)
    given = [v is not None for v in (args.E, args.D, args.lam)]
    if any(given) and not all(given):
        raise ValueError("give all of --E --D --lam, or a state with --theta0 --omega3")
    if all(given):
        E, D, lam, z0 = args.E, args.D, args.lam, None
    elif args.theta0 is not None and args.omega3 is not None:
        state = _state_from_args(args, top)
        E, D, lam = (
            float(f(top, state)) for f in (integrals.energy, integrals.routh, integrals.jellett)
        )
        import math

        z0 = math.cos(args.theta0)
    else:
        raise ValueError("give --E --D --lam, or a rolling state with --theta0 --omega3")
    band = separation.band(top, E, D, lam, z0=z0)
    print(f"E [J], D [kg m^2/s], lam [kg m^3/s]  {E!r}, {D!r}, {lam!r}")
    print(f"motion                 {band.kind}")
    if band.kind == "none":
        raise ValueError(f"no admissible motion: E lies {-band.depth:.3g} J below the minimum of V")
    import math

    print(f"turning points z       {band.z_low:.10g}, {band.z_high:.10g}")
    print(f"turning points theta   {math.acos(band.z_high):.10g}, {math.acos(band.z_low):.10g} rad")
    print(f"nutation period [s]    {separation.nutation_period(top, E, D, lam, z0=z0):.10g}")
    print(f"mean precession [rad/s] {separation.mean_precession(top, E, D, lam, z0=z0):.10g}")
    return 0


def _cmd_figures(args: argparse.Namespace) -> int:
    from . import gallery

    paths = gallery.generate(args.out, animation=not args.no_animation, progress=not args.quiet)
    from pathlib import Path

    (Path(args.out) / "README.md").write_text(gallery.index_markdown(paths), encoding="utf-8")
    for p in paths:
        print(f"wrote {p}")
    return 0


def _parse_grid(specs: list[str]) -> dict:
    import numpy as np

    grid = {}
    for spec in specs:
        name, sep, rng = spec.partition("=")
        parts = rng.split(":")
        if not sep or len(parts) != 3:
            raise ValueError(f"--grid takes name=start:stop:num; got {spec!r}")
        try:
            start, stop, num = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise ValueError(
                f"--grid takes name=start:stop:num with numbers; got {spec!r}"
            ) from None
        if num < 1:
            raise ValueError(f"--grid num must be >= 1; got {spec!r}")
        grid[name.strip()] = np.linspace(start, stop, num)
    return grid


def _cmd_sweep(args: argparse.Namespace) -> int:
    from concurrent.futures import ProcessPoolExecutor

    from .sweeps import sweep

    top = _top_from_args(args)
    grid = _parse_grid(args.grid)
    kw = dict(
        t_end=args.t_end, theta0=args.theta0, omega3=args.omega3, progress=args.progress,
        checkpoint=args.checkpoint, model=args.model, rtol=args.rtol,
    )  # fmt: skip
    if args.scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise ValueError("--scheduler needs Dask: pip install 'mett[dask]'") from None
        with Client(args.scheduler) as client:
            table = sweep(top, grid, executor=client.get_executor(), **kw)
    elif args.workers > 1:
        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            table = sweep(top, grid, executor=pool, **kw)
    else:
        table = sweep(top, grid, **kw)
    table.to_csv(args.out, index=False)
    counts = table["simulated"].value_counts().to_dict()
    print(f"wrote {args.out}: {len(table)} runs, end states {counts}, "
          f"{int(table['agree'].sum())} agree with the prediction")  # fmt: skip
    return 0


def _build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="mett", description="Tippe-top dynamics around the METT.")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    sub.required = True
    p = sub.add_parser("info", help="parameters, thresholds and group of a top")
    _add_top_arguments(p)
    p.add_argument("--theta0", type=float, default=0.1, help="start angle for the minimal spin")
    p.set_defaults(func=_cmd_info)

    from .dynamics import MODELS

    p = sub.add_parser("simulate", help="simulate a top; print the inversion time and end state")
    _add_top_arguments(p)
    _add_state_arguments(p, required=True)
    p.add_argument("--t-end", type=float, required=True, help="simulated time [s]")
    p.add_argument("--model", default="gliding", choices=sorted(MODELS))
    p.add_argument("--rtol", type=float, default=1e-10)
    p.add_argument("--out", default=None, help="write the trajectory (.csv or .npz)")
    p.add_argument("--plot", default=None, help="write θ(t) as an image (e.g. theta.png)")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("period", help="turning points, nutation period and precession (rolling)")
    _add_top_arguments(p)
    p.add_argument("--E", type=float, default=None, help="energy [J]")
    p.add_argument("--D", type=float, default=None, help="Routh integral [kg m^2/s]")
    p.add_argument("--lam", type=float, default=None, help="Jellett integral [kg m^3/s]")
    _add_state_arguments(p, required=False)
    p.set_defaults(func=_cmd_period)

    p = sub.add_parser("sweep", help="simulate a grid of parameters; write a CSV table")
    _add_top_arguments(p)
    p.add_argument(
        "--grid", action="append", required=True, metavar="NAME=START:STOP:NUM",
        help="a swept parameter (repeat for more): a TippeTop field, an initial condition, "
        "gamma or lam_ratio",
    )  # fmt: skip
    p.add_argument("--t-end", type=float, required=True, help="simulated time per run [s]")
    p.add_argument("--theta0", type=float, default=0.1, help="θ(0) [rad]")
    p.add_argument("--omega3", type=float, default=155.0, help="ω3(0) [rad/s]")
    p.add_argument("--model", default="gliding", choices=sorted(MODELS))
    p.add_argument("--rtol", type=float, default=1e-10)
    p.add_argument("--out", default="sweep.csv", help="output CSV")
    p.add_argument("--workers", type=int, default=1, help="processes on this machine")
    p.add_argument("--scheduler", default=None, help="address of a running Dask scheduler")
    p.add_argument("--checkpoint", default=None, help="JSON-lines checkpoint to resume from")
    p.add_argument("--progress", action="store_true", help="progress bar (needs tqdm)")
    p.set_defaults(func=_cmd_sweep)

    p = sub.add_parser("figures", help="regenerate every published figure")
    p.add_argument("--out", default="figures", help="output directory")
    p.add_argument("--no-animation", action="store_true", help="skip the GIF")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_figures)
    return parser


def _add_state_arguments(p: argparse.ArgumentParser, *, required: bool) -> None:
    p.add_argument("--theta0", type=float, required=required, default=None, help="θ(0) [rad]")
    p.add_argument("--omega3", type=float, required=required, default=None, help="ω3(0) [rad/s]")
    p.add_argument("--thetadot", type=float, default=0.0, help="θ̇(0) [rad/s]")
    p.add_argument("--phidot", type=float, default=0.0, help="φ̇(0) [rad/s]")
    p.add_argument(
        "--cm-at-rest", action="store_true", help="start with the CM at rest instead of ν(0) = 0"
    )


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
