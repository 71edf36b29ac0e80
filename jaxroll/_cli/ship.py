"""`jaxroll ship show`: print a ship's parameters with their provenance."""

from __future__ import annotations

import json

from ._common import load_ship_arg, to_jsonable


def register(sub) -> None:
    p = sub.add_parser("ship", help="show ship parameters (default: C11 representative)")
    ssub = p.add_subparsers(dest="ship_command", metavar="ACTION", required=True)
    show = ssub.add_parser("show", help="print the ship's coefficients and where they come from")
    show.add_argument(
        "--ship", metavar="FILE", default=None, help="ship file (TOML); default: C11 (representative)"
    )
    show.add_argument("--json", action="store_true", help="print JSON instead of the ship file (TOML)")
    show.set_defaults(func=run_show)


def run_show(args) -> int:
    from ..io import ship_to_dict, ship_to_toml
    from ..ship import righting_lever, vanishing_angle

    ship = load_ship_arg(args.ship)
    import jax.numpy as jnp

    phi = jnp.deg2rad(jnp.linspace(0.0, 90.0, 9001))
    gz = righting_lever(ship, phi)
    derived = {
        "omega0_rad_s": float(ship.omega0),
        "vanishing_angle_deg": float(jnp.rad2deg(vanishing_angle(ship))),
        "gz_max_m": float(gz.max()),
        "gz_max_angle_deg": float(jnp.rad2deg(phi[jnp.argmax(gz)])),
        "damping_ratio_linear": float(ship.damping[0] / (2 * ship.omega0)),
    }
    if args.json:
        print(json.dumps(to_jsonable({**ship_to_dict(ship), "derived": derived}), indent=2))
    else:
        print(ship_to_toml(ship), end="")
        print("\n# derived (not part of the file):")
        for k, v in derived.items():
            print(f"# {k} = {v:.6g}")
    return 0
