"""Captive and free-running records as labs hand them over (issue 43 item 7): the tank at rest before the waves
reach the probe (found; said when the analysis window starts in it; skipped by the default time-domain span), the
roll offset of a slightly heeled model removed, angle and ΔGM unit slips warned — on generated records."""

import math
import warnings

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxroll as jxr
from jaxroll.calibration import (
    fit_captive,
    fit_roll_time_domain,
    virtual_captive_record,
    virtual_roll_record,
)
from jaxroll.calibration._inputs import lab_records, waves_arrive
from jaxroll.calibration._time_domain import analysis_span
from jaxroll.io import make_record

SHIP = jxr.c11_representative()
TRUTH = eqx.tree_at(lambda s: s.gm_correction, SHIP, jnp.asarray(0.8))
SEA = jxr.ITTC(7.0, 10.0)
REST_S, OFFSET_DEG = 20.0, 0.4  # model scale; a model heeled by 0.4°


def _with_rest(rec, rest_model_s=REST_S, offset_deg=0.0, seed=1):
    """`rec` later by `rest_model_s` of calm tank (sensor noise only) before it, its roll about `offset_deg`."""
    n = int(round(rest_model_s * rec.meta["sampling_hz"]))
    rng = np.random.default_rng(seed)
    noise = {"roll": math.radians(0.05), "wave": 1e-4 * rec.scale, "delta_gm": 1e-5}
    channels = {
        k: np.concatenate([noise[k] * rng.standard_normal(n), v])
        + (math.radians(offset_deg) if k == "roll" else 0)
        for k, v in rec.channels.items()
    }
    time = np.arange(rec.time.size + n) * rec.dt
    meta = {k: v for k, v in rec.meta.items() if k not in ("scale", "sampling_hz", "format_version", "units")}
    return make_record(rec.kind, time, channels, scale=rec.scale, sampling_hz=rec.meta["sampling_hz"], **meta)


@pytest.fixture(scope="module")
def roll_pair():
    rec, _ = virtual_roll_record(
        TRUTH, SEA, seed=2, duration_model_s=150.0, roll_noise_deg=0.05, wave_noise_mm=0.1
    )
    return rec, _with_rest(rec, offset_deg=OFFSET_DEG)


def test_rest_found_offset_removed_and_said(roll_pair):
    clean, lab = roll_pair
    t_arrive = lab.model_time[waves_arrive(lab)]
    period_model = 10.0 / math.sqrt(lab.scale)
    assert REST_S <= t_arrive < REST_S + period_model  # the first wave at the probe, within one wave period
    assert lab.model_time[waves_arrive(clean)] < period_model  # in waves from the start: no rest
    with pytest.warns(UserWarning, match=r"the tank is calm until 2\d\.\d s \(model scale\).* starts at 0 s"):
        lab_records([lab], (0.0, 170.0))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (fixed,) = lab_records([lab], (30.0, 170.0))
    assert fixed.meta["roll_offset_deg"] == pytest.approx(OFFSET_DEG, abs=0.05)
    # the roll about the offset is the clean record's, to the offset's estimation error
    shift = int(round(REST_S * lab.meta["sampling_hz"]))
    assert np.max(np.abs(np.degrees(fixed.roll[shift:] - clean.roll))) < 0.05
    # the default time-domain span of a record that does not cover 70–340 s starts 5·T01 after the waves arrive
    i0, _ = analysis_span(lab, None)
    assert lab.model_time[i0] == pytest.approx(t_arrive + 5 * period_model, abs=0.06)


def test_time_domain_fit_is_blind_to_rest_and_offset(roll_pair):
    """The same data, 20 s later and about 0.4°: the same estimates (within 1 standard error: b1 0.31, gm_correction
    0.68 SE apart, from the offset's estimation error of 0.004°)."""
    clean, lab = roll_pair
    kw = {"params": ("b1", "gm_correction")}
    a = fit_roll_time_domain(SHIP, clean, span_model_s=(20.0, 140.0), **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        b = fit_roll_time_domain(SHIP, lab, span_model_s=(40.0, 160.0), **kw)
    assert b.config["roll_offset_deg"][0] == pytest.approx(OFFSET_DEG, abs=0.05)
    for k in kw["params"]:
        ea, eb = a.estimates[k], b.estimates[k]
        assert abs(ea.value - eb.value) < ea.std_error, (k, ea, eb)
    assert abs(b.estimates["gm_correction"].value - 0.8) < 0.004  # (the truth; 0.1 % off at this noise)


def test_unit_slips_of_roll_and_delta_gm_are_said(roll_pair):
    clean, _ = roll_pair
    as_deg = make_record(
        "roll",
        clean.time,
        {"roll": np.radians(clean.roll), "wave": clean.wave},  # radians labelled degrees
        scale=clean.scale,
        sampling_hz=clean.meta["sampling_hz"],
        **{
            k: v
            for k, v in clean.meta.items()
            if k not in ("scale", "sampling_hz", "format_version", "units")
        },
    )
    with pytest.warns(
        UserWarning, match=r"the roll reaches only 0\.\d+°; if the roll column is in radians labelled"
    ):
        lab_records([as_deg], (0.0, 150.0))
    cap = virtual_captive_record(TRUTH, SEA, heel_deg=5.0, duration_model_s=360.0, seed=3)
    slip = make_record(
        "captive",
        cap.time,
        {"wave": cap.wave, "delta_gm": cap.delta_gm * 1e3},  # mm read as m
        scale=cap.scale,
        sampling_hz=cap.meta["sampling_hz"],
        **{k: v for k, v in cap.meta.items() if k not in ("scale", "sampling_hz", "format_version", "units")},
    )
    with pytest.warns(
        UserWarning, match=r"σ_obs/σ_thr = 8\d\d: the measured ΔGM is .*; likely ΔGM in mm labelled m"
    ):
        fit = fit_captive([slip], SHIP)
    assert 700 < fit.std_ratio.value < 900
    with pytest.warns(UserWarning, match=r"the tank is calm until 2\d\.\d s"):
        fit_captive([_with_rest(cap)], SHIP, window_model_s=(0.0, 300.0))
