"""Command-line options shared by every subcommand that simulates a sea state.

Headings: degrees here (0° following, 90° beam, 180° head; `head`/`following` accepted), radians in the API.
"""

from __future__ import annotations

import argparse
import functools
import math

from ._common import CLIError


def add_sea_options(p: argparse.ArgumentParser, *, spreading: bool = True) -> None:
    """--hs --t01 --speed --heading [--spreading] --ship --dt --method --filter-order --seed."""
    g = p.add_argument_group("sea state and ship (full scale)")
    g.add_argument("--hs", type=float, default=7.0, help="significant wave height H1/3 [m] (default 7)")
    g.add_argument("--t01", type=float, default=10.0, help="mean wave period T01 [s] (default 10)")
    g.add_argument("--speed", type=float, default=0.0, help="ship speed [m/s] (default 0)")
    g.add_argument(
        "--heading",
        type=normalise_heading,
        default="head",
        metavar="DEG",
        help="heading χ [deg] of the waves (their mean direction when short-crested) relative to the course: "
        "0 following, 90 beam, 180 head; or head / beam / following (default head)",
    )
    if spreading:
        add_spreading_option(g)
    g.add_argument(
        "--ship",
        metavar="FILE",
        default=None,
        help="ship file (TOML), or `c11-hull` for GZ and ΔGM computed from the shipped representative hull; "
        "default: C11 (representative)",
    )
    n = p.add_argument_group("numerics")
    n.add_argument("--dt", type=float, default=0.5, help="time step [s] (default 0.5)")
    n.add_argument(
        "--method",
        choices=("auto", "filter", "superposition"),
        default="auto",
        help="effective wave: Method 2 shaping filter (paper's MCS), Method 1 superposition, or auto (default): "
        "the filter, but superposition when the ship carries a wave moment and the heading is oblique or beam "
        "(the moment and the effective wave from the same waves, docs/wave_moment.md)",
    )
    n.add_argument(
        "--filter-order",
        type=_filter_order,
        default="auto",
        help="order of the Method-2 filter, or auto (default): 4, or 8 where 4 does not follow the effective-wave "
        "spectrum within 5 %% where the roll is excited (4 is the paper's; the moment method keeps 4 under auto)",
    )
    n.add_argument("--seed", type=int, default=0, help="random seed (default 0)")


def add_spreading_option(group) -> None:
    """--spreading cos2s:S | cosn:N | none (checked by `spreading_from_args`)."""
    group.add_argument(
        "--spreading",
        default="none",
        metavar="KIND",
        help="directional spreading of a short-crested sea about --heading: cos2s:S (D ∝ cos^2s(θ/2), e.g. "
        "cos2s:10 wind sea, cos2s:25 to cos2s:75 swell), cosn:N (D ∝ cos^n θ, e.g. cosn:2), or none "
        "(long-crested, the default; docs/spreading.md)",
    )


def spreading_from_args(args):
    """The `jaxroll.sea.Spreading` of --spreading, or None (`none`, or a command without the option). Raises
    CLIError."""
    from ..sea import parse_spreading

    text = getattr(args, "spreading", "none")
    try:
        return parse_spreading(text)
    except ValueError as e:
        raise CLIError(f"--spreading: {e}") from None


def spreading_label(args) -> str:
    """--spreading as the JSON and the printed lines write it: `cos2s:10`, `cosn:2` or `none`."""
    spreading = spreading_from_args(args)
    return "none" if spreading is None else spreading.label()


def add_yaw_options(p: argparse.ArgumentParser) -> None:
    """--yaw-std --yaw-time (docs/yaw.md)."""
    g = p.add_argument_group("yaw (the heading wanders about --heading along each run; docs/yaw.md)")
    g.add_argument(
        "--yaw-std",
        type=float,
        default=0.0,
        metavar="DEG",
        help="standard deviation σ_ψ [deg] of an Ornstein–Uhlenbeck yaw, 0 to 45 (default 0: no yaw); at --speed 0, "
        "with the superposition; a ship carrying a wave moment feels it at every heading, head seas included",
    )
    g.add_argument(
        "--yaw-time",
        type=float,
        default=30.0,
        metavar="S",
        help="the yaw's correlation time τ [s] (default 30)",
    )


def yaw_from_args(args):
    """The `Yaw` of --yaw-std/--yaw-time, None without yaw (σ_ψ = 0 or a command without the options). Raises
    CLIError for values out of range, yaw at forward speed, or with --method filter."""
    from ..roll import Yaw

    std, tau = getattr(args, "yaw_std", 0.0), getattr(args, "yaw_time", 30.0)
    if not (math.isfinite(tau) and tau > 0):
        raise CLIError(f"--yaw-time must be a finite number > 0 [s]; got {tau:g}.")
    try:
        yaw = Yaw(math.radians(std), tau)
    except ValueError as e:
        raise CLIError(f"--yaw-std {std:g}: {e}") from None
    if std == 0:
        return None
    if args.speed != 0:
        raise CLIError(
            f"--yaw-std at --speed {args.speed:g}: yaw at forward speed is not modelled (the encounter frequency "
            "would follow the heading); use --speed 0 or --yaw-std 0 (docs/yaw.md)."
        )
    if args.method == "filter":
        raise CLIError(
            "--yaw-std needs --method superposition or auto: a shaping filter cannot make an effective wave whose "
            "weight follows the heading (docs/yaw.md)."
        )
    return yaw


def refuse_theories_under_yaw(args, names) -> None:
    """Raise CLIError when theories (`names`, e.g. roberts, first_passage) are asked for a run whose heading yaws:
    each covers one fixed heading (`jaxroll.theory.yaw_refusal`)."""
    if names and yaw_from_args(args) is not None:
        from ..theory import yaw_refusal

        raise CLIError(yaw_refusal(names[0]))


def word_or_number(word: str, convert=int):
    """An argparse type: `word` (any case), a number by `convert`, or the text as given — refused later by the
    option's own check, with its name (argparse's own refusal would not name the fix)."""

    def parse(text: str):
        if str(text).strip().lower() == word:
            return word
        try:
            return convert(text)
        except ValueError:
            return text

    return parse


#: --filter-order: 'auto' or an integer (checked by `check_filter_order`).
_filter_order = word_or_number("auto", int)


def moment_filter_order(args) -> int:
    """The filter order the moment method uses: --filter-order, or the paper's 4 under auto (the closure's size
    grows like C(n + 8, 6) with the filter's order n: 924 moments at n = 4, 8008 at n = 8)."""
    return 4 if args.filter_order == "auto" else args.filter_order


def moment_filter(problem, args):
    """The Monte Carlo's own filter fit for the moment method when it has the moment method's order, else None
    (the moment method then fits its own, of `moment_filter_order`)."""
    fit = problem.filter_fit
    return fit if fit is not None and fit.filter.order == moment_filter_order(args) else None


_NAMED_HEADINGS = {"head": 180.0, "beam": 90.0, "following": 0.0}  # χ [deg]


def heading_number(text: str) -> float | None:
    """Degrees from 'head', 'beam', 'following', '135', '135deg' or '135°'; None when it is none of those."""
    t = str(text).strip().lower()
    if t in _NAMED_HEADINGS:
        return _NAMED_HEADINGS[t]
    for suffix in ("deg", "°"):
        t = t.removesuffix(suffix)
    try:
        value = float(t)
    except ValueError:
        return None
    return value if 0.0 <= value <= 180.0 else None


def parse_heading(text: str) -> float:
    """Heading χ [deg] in [0, 180] from the command line ('head' = 180, 'beam' = 90, 'following' = 0). Raises
    CLIError."""
    value = heading_number(text)
    if value is None:
        raise CLIError(
            f"--heading must be head, following, beam or an angle in degrees in [0, 180] (0 following, 90 beam, "
            "180 head); "
            f"got {text!r}."
        )
    return value


def heading_label(deg: float) -> str:
    """The heading's name in JSON and folder names: 'head' (180°), 'following' (0°) or e.g. '135deg'."""
    return "head" if deg == 180.0 else "following" if deg == 0.0 else f"{deg:g}deg"


def has_yaw(problem) -> bool:
    """Whether a `RollProblem`'s heading yaws (`jaxroll.Yaw`)."""
    return getattr(getattr(problem, "excitation", None), "yaw", None) is not None


def heading_phrase(deg: float) -> str:
    """The heading in words for printed lines and titles, e.g. 'head seas' or 'oblique seas (χ = 135°)'."""
    if deg in (0.0, 180.0):
        return f"{heading_label(deg)} seas"
    return f"{'beam' if deg == 90.0 else 'oblique'} seas (χ = {deg:g}°)"


def sea_heading_phrase(args) -> str:
    """`heading_phrase` of --heading, with the spreading when the sea is short-crested (e.g. 'head seas,
    short-crested cos2s:10')."""
    phrase = heading_phrase(parse_heading(args.heading))
    label = spreading_label(args)
    return phrase if label == "none" else f"{phrase}, short-crested {label}"


def heading_for_api(deg: float) -> str | float:
    """What `RollProblem.from_sea` takes: 'head' / 'following' (today's exact path) or χ [rad]."""
    return heading_label(deg) if deg in (0.0, 180.0) else math.radians(deg)


def normalise_heading(text: str) -> str:
    """argparse type of --heading: the canonical label of a valid heading, else the text (checked later)."""
    value = heading_number(text)
    return text if value is None else heading_label(value)


def check_positive(args, *names: str) -> None:
    """Raise CLIError unless every named option that is given (not None) is a finite number > 0."""
    for name in names:
        value = getattr(args, name)
        if value is not None and not (math.isfinite(value) and value > 0):
            raise CLIError(f"--{name.replace('_', '-')} must be a finite number > 0; got {value}.")


#: The Monte Carlo keeps the capsize step as an int32 (`jaxroll.simulate`): at most this many time steps per trial.
MAX_STEPS = 2**31 - 1


def check_steps(dt: float, durations: dict[str, float]) -> None:
    """Refuse a run whose trials would have more time steps than the Monte Carlo can count (`MAX_STEPS`), from the
    options alone — before any fit or compilation. `durations`: what the options say, in words (e.g.
    `"--duration"`, `"--discard + --hours"`) → simulated time [s]; `dt` [s] and the durations already checked
    finite and > 0."""
    for what, seconds in durations.items():
        steps = seconds / dt
        if steps > MAX_STEPS:
            raise CLIError(
                f"{what} / --dt = {seconds:g} s / {dt:g} s = {steps:.3g} time steps per realization; the Monte Carlo "
                f"counts at most 2³¹ − 1 = {MAX_STEPS:.3g} (and 10⁴ realizations of 10⁹ steps take days): lengthen "
                f"--dt (the paper: 0.5 s) or shorten {what}."
            )


def resolved_method(args, ship) -> str:
    """--method with `auto` resolved as `RollProblem.from_sea` resolves it: "superposition" when the ship carries a
    wave moment and the heading is oblique or beam (|cos χ| < 1), else "filter"."""
    if args.method != "auto":
        return args.method
    if yaw_from_args(args) is not None:
        return "superposition"
    oblique = abs(math.cos(math.radians(parse_heading(args.heading)))) < 1 - 1e-15
    # a short-crested sea has oblique directions at every heading
    spread = spreading_from_args(args) is not None
    moment = ship.wave_moment is not None and (oblique or spread)
    return "superposition" if moment else "filter"


def sea_config(args, ship) -> dict:
    """The sea/numerics part of a run's configuration, for JSON provenance."""
    from .. import ship_to_dict
    from ..ship import DEFAULT_SHIP_NOTE

    cfg = {
        "sea": {"spectrum": "ITTC", "hs_m": args.hs, "t01_s": args.t01},
        "speed_m_s": args.speed,
        "heading": heading_label(parse_heading(args.heading)),
        "heading_deg": parse_heading(args.heading),
        "heading_convention": "χ between the course and the wave direction: 0° following, 90° beam, 180° head",
        "spreading": spreading_label(args),
        "ship": ship_to_dict(ship),
        "ship_file": args.ship,
        "dt_s": args.dt,
        "method": resolved_method(args, ship),
        "filter_order": args.filter_order,
        "seed": args.seed,
    }
    if args.ship is None:
        cfg["ship_note"] = DEFAULT_SHIP_NOTE
    if yaw_from_args(args) is not None:
        cfg["yaw"] = {
            "std_deg": args.yaw_std,
            "correlation_time_s": args.yaw_time,
            "model": "Ornstein-Uhlenbeck",
        }
    return cfg


def check_filter_order(args) -> None:
    """--filter-order within what `fit_filter` takes: the Method-2 filter's order, and the moment method's
    (whatever --method is)."""
    from ..sea import MAX_FILTER_ORDER

    order = args.filter_order
    if order != "auto" and not (isinstance(order, int) and 3 <= order <= MAX_FILTER_ORDER):
        raise CLIError(
            f"--filter-order must be auto or an integer between 3 and {MAX_FILTER_ORDER} (auto recommended, 4 the "
            f"paper's); got {order!r}."
        )


def check_sea_options(args) -> None:
    """The shared sea-state and numerics options (`add_sea_options`): H1/3, T01 and dt finite and > 0, the speed a
    finite magnitude, the filter order within `fit_filter`'s range. Commands call it before any fit or compile."""
    check_positive(args, "hs", "t01", "dt")
    if not (math.isfinite(args.speed) and args.speed >= 0):
        raise CLIError(f"--speed must be >= 0 [m/s] (use --heading for direction); got {args.speed}.")
    check_filter_order(args)
    spreading_from_args(args)
    yaw_from_args(args)


def _sea_from_args(args, ship):
    """The ITTC sea and the heading [deg] of the options, checked (the beam-sea note printed)."""
    from .. import ITTC

    heading_deg = parse_heading(args.heading)
    check_sea_options(args)
    if spreading_from_args(args) is not None:
        print(
            f"Short-crested sea: spreading {spreading_label(args)} about the mean heading χ = {heading_deg:g}° "
            "(Grim's effective wave summed over directions; docs/spreading.md)."
        )
    elif heading_deg == 90.0 and ship.wave_moment is not None:
        print(
            "Beam seas (χ = 90°): no parametric excitation (Grim's effective wave vanishes); the roll is driven by "
            "the direct wave moment the ship carries (docs/wave_moment.md)."
        )
    elif heading_deg == 90.0:
        print(
            "Beam seas (χ = 90°): the wave number projected on the ship's axis, k·cos χ, is 0, so Grim's effective "
            "wave and the parametric excitation vanish in this model: no parametric roll (the roll only decays "
            "from its initial angle)."
        )
    return ITTC(args.hs, args.t01), heading_deg


def build_problem(args, ship, *, phi0_deg: float = 5.0):
    """`RollProblem.from_sea` from the parsed options. **Returns:** `(problem, filter_fit, sea)`."""
    from .. import RollProblem

    if not math.isfinite(phi0_deg):
        raise CLIError(f"--phi0-deg must be finite; got {phi0_deg}.")
    sea, heading_deg = _sea_from_args(args, ship)
    problem = RollProblem.from_sea(
        ship,
        sea,
        speed=args.speed,
        heading=heading_for_api(heading_deg),
        excitation=resolved_method(args, ship),
        dt=args.dt,
        filter_order=args.filter_order,
        phi0=math.radians(phi0_deg),
        spreading=spreading_from_args(args),
        yaw=yaw_from_args(args),
    )
    return problem, problem.filter_fit, sea


class TheoryInputs:
    """What the theories take from a sea state — the ship, Grim's effective wave and the shaping-filter fit (None
    with --method superposition) — as `RollProblem.from_sea` builds them, without the Monte Carlo's time stepping.

    The fit (and its check) is made when `filter_fit` is first read: only the moment method uses it, so
    `start_theory_summaries` dispatches the other theories' programs first and they trace and compile while the
    fit runs (a cold `jaxroll theory`: the fit's ≈ 2.5 s of export and compilation off the critical path)."""

    def __init__(self, args, ship, wave):
        self.ship, self.wave = ship, wave
        self._args = args

    @functools.cached_property
    def filter_fit(self):
        from ..sea import check_filter_fit, fit_filter

        if resolved_method(self._args, self.ship) != "filter":
            return None
        fit = fit_filter(
            self.wave, order=moment_filter_order(self._args), match_frequency=2 * self.ship.omega0
        )
        check_filter_fit(fit)
        return fit


def build_theory_inputs(args, ship) -> TheoryInputs:
    """The theories' inputs from the parsed options: the same wave and filter fit (gated by the same checks) as
    `build_problem`, without the time-step check and the excitation's discretisation, which only the Monte Carlo
    needs; the fit is made when first used (`TheoryInputs`)."""
    from .. import EffectiveWave

    sea, heading_deg = _sea_from_args(args, ship)
    wave = EffectiveWave(
        sea, ship.lpp, args.speed, heading_for_api(heading_deg), spreading=spreading_from_args(args)
    )
    return TheoryInputs(args, ship, wave)
