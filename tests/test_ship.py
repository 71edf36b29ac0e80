"""Ship parameters, ship files and the restoring/ΔGM polynomials."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll


def test_default_ship_matches_conventions():
    s = jaxroll.c11_representative()
    assert s.name == "C11 (representative)" and "representative" in s.provenance
    np.testing.assert_allclose(s.omega0, 0.257508, atol=1e-6, rtol=0)
    np.testing.assert_allclose(s.damping[0], 0.0077252, atol=1e-7, rtol=0)
    np.testing.assert_allclose(jnp.rad2deg(jaxroll.vanishing_angle(s)), 71.6, atol=0.05, rtol=0)
    phi = jnp.deg2rad(jnp.linspace(0, 80, 8001))
    gz = jaxroll.righting_lever(s, phi)
    np.testing.assert_allclose(gz.max(), 1.14, atol=0.005, rtol=0)  # CONVENTIONS: GZ max ≈ 1.14 m at 46°
    np.testing.assert_allclose(jnp.rad2deg(phi[jnp.argmax(gz)]), 46.0, atol=0.5, rtol=0)
    # GM0 is the slope of GZ at the origin.
    np.testing.assert_allclose(
        jax.grad(lambda p: jaxroll.righting_lever(s, p))(0.0), s.gm0, rtol=1e-12, atol=0
    )


def test_vanishing_angle_closed_form():
    # a1 + a3 x + a5 x² = 0 with x = φ²: x² + x − 4 = 0 for the default ship.
    s = jaxroll.c11_representative()
    np.testing.assert_allclose(jaxroll.vanishing_angle(s), np.sqrt((np.sqrt(17) - 1) / 2), rtol=1e-10, atol=0)
    with pytest.warns(UserWarning, match="GZ never returns to zero"):
        linear = jaxroll.ship_from_dict(
            {**jaxroll.ship_to_dict(s), "restoring": {"a3": 0.0, "a5": 0.0, "a7": 0.0, "a9": 0.0}}
        )
    np.testing.assert_allclose(jaxroll.vanishing_angle(linear), np.pi, rtol=0, atol=0)


def test_delta_gm_sign_convention():
    s = jaxroll.c11_representative()
    # Trough amidships (ζ_mid > 0) raises GM for the default ship (C1 > 0); P uses ζ_mid = −ζ_G.
    np.testing.assert_allclose(jaxroll.delta_gm(s, 2.0), 0.55 * 2 + 0.05 * 4 - 0.004 * 8, rtol=1e-14, atol=0)
    p = jaxroll.parametric_excitation(s, -2.0)  # ζ_G = −2 m: trough amidships
    np.testing.assert_allclose(p, s.omega0**2 / s.gm0 * jaxroll.delta_gm(s, 2.0), rtol=1e-14, atol=0)
    half = jaxroll.ship_from_dict({**jaxroll.ship_to_dict(s), "correction": {"gm_ratio": 0.5}})
    np.testing.assert_allclose(
        jaxroll.parametric_excitation(half, 1.3),
        0.5 * jaxroll.parametric_excitation(s, 1.3),
        rtol=1e-14,
        atol=0,
    )


def test_ship_file_round_trip(tmp_path):
    s = jaxroll.c11_representative()
    path = tmp_path / "ship.toml"
    path.write_text(jaxroll.ship_to_toml(s))
    back = jaxroll.load_ship(path)
    assert jaxroll.ship_to_dict(back) == jaxroll.ship_to_dict(s)


def _write(tmp_path, text):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


def test_ship_file_errors(tmp_path):
    good = jaxroll.ship_to_toml(jaxroll.c11_representative())
    with pytest.raises(FileNotFoundError, match="does not exist"):
        jaxroll.load_ship(tmp_path / "nope.toml")
    with pytest.raises(ValueError, match="not valid TOML"):
        jaxroll.load_ship(_write(tmp_path, "lpp_m = = 3"))
    with pytest.raises(ValueError, match=r"missing field\(s\) \[damping\] b2"):
        jaxroll.load_ship(_write(tmp_path, good.replace("b2 = 0.5\n", "")))
    with pytest.raises(ValueError, match=r"unknown field\(s\) \['b4'\] in \[damping\]"):
        jaxroll.load_ship(_write(tmp_path, good.replace("b2 = 0.5\n", "b2 = 0.5\nb4 = 1.0\n")))
    with pytest.raises(ValueError, match=r"unknown top-level field\(s\) \['hull'\]"):
        jaxroll.load_ship(_write(tmp_path, "[hull]\nx = 1\n" + good))
    with pytest.raises(ValueError, match=r"\[particulars\] gm0_m must be a number"):
        jaxroll.load_ship(_write(tmp_path, good.replace("gm0_m = 1.9299", 'gm0_m = "big"')))
    with pytest.raises(ValueError, match=r"gm0_m = -1.0 must be > 0"):
        jaxroll.load_ship(_write(tmp_path, good.replace("gm0_m = 1.9299", "gm0_m = -1.0")))
    with pytest.raises(ValueError, match="damping coefficients must be >= 0"):
        jaxroll.load_ship(_write(tmp_path, good.replace("b2 = 0.5", "b2 = -0.5")))
    with pytest.raises(ValueError, match="draught_m = 30.0 must be below depth_m"):
        jaxroll.load_ship(_write(tmp_path, good.replace("draught_m = 11.5", "draught_m = 30.0")))
    with pytest.raises(ValueError, match="must be a finite number"):
        jaxroll.load_ship(_write(tmp_path, good.replace("b1 = ", "b1 = nan #")))
    with pytest.raises(ValueError, match=r"block_coefficient = 1.5 must be in \(0, 1\]"):
        jaxroll.load_ship(
            _write(tmp_path, good.replace("block_coefficient = 0.56", "block_coefficient = 1.5"))
        )
    with pytest.raises(ValueError, match="gm_ratio = -1.0 must be >= 0"):
        jaxroll.load_ship(_write(tmp_path, good.replace("gm_ratio = 1.0", "gm_ratio = -1.0")))
    with pytest.raises(ValueError, match=r"`restoring` must have shape \(4,\)"):
        jaxroll.Ship(**{**_kwargs(), "restoring": [0.0, 0.0]})


def _kwargs():
    return dict(
        lpp=1.0,
        breadth=1.0,
        depth=1.0,
        draught=0.5,
        displacement=1.0,
        block_coefficient=0.5,
        gm0=0.1,
        roll_period=10.0,
        restoring=[0.0] * 4,
        damping=[0.0] * 3,
        delta_gm=[0.0] * 7,
    )


def test_validate_ship_refuses_absurd_period_and_gz_without_vanishing_angle():
    """Issue 13: a roll period of 1e6 s and a GZ that never returns to zero were accepted silently."""
    import equinox as eqx

    from jaxroll.ship._ship import validate_ship

    ship = jaxroll.c11_representative()
    validate_ship(ship)
    slow = eqx.tree_at(lambda s: s.roll_period, ship, jnp.asarray(1e6))
    with pytest.raises(ValueError, match="roll period 1e\\+06 s"):
        validate_ship(slow)
    stiff = eqx.tree_at(lambda s: s.restoring, ship, jnp.abs(ship.restoring))
    with pytest.warns(UserWarning, match="GZ never returns to zero"):
        validate_ship(stiff)
