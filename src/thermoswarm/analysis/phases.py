"""One phase against two on a set of energies, and the plausibility of the fitted
temperatures.

:func:`phase_block` runs :func:`~thermoswarm.analysis.fit.compare_phases` on the
energies of a mask of steps with a test sample thinned by the energies' decorrelation
lag (:mod:`thermoswarm.analysis.sampling`); :func:`plausibility` checks each fitted
temperature against the animal's speed bound.  Units: energies in the kinematics'
unit (mm^2/s^2, or J with a mass), speeds in mm/s.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import xarray as xr

from thermoswarm.analysis.phase_tests import PhaseComparison, compare_phases
from thermoswarm.analysis.sampling import (
    autocorrelation,
    decorrelation_lag,
    draw_test_sample,
    integrated_autocorr_time,
)

__all__ = ["MIN_SAMPLES", "dependence", "test_sample_info", "phase_block", "plausibility"]

#: Fewer valid samples than this in a group or bin: reported, not fitted.
MIN_SAMPLES = 20


def dependence(values: np.ndarray, valid: np.ndarray) -> dict[str, Any]:
    """Within-track dependence of a variable: decorrelation lag and tau (in steps)."""
    rho = autocorrelation(values, valid)
    tau = integrated_autocorr_time(values, valid, rho=rho)
    return {
        "decorrelation_lag": decorrelation_lag(values, valid, rho=rho),
        "tau_int": None if not np.isfinite(tau) else float(tau),
    }


def test_sample_info(info: dict[str, Any], dep: dict[str, Any]) -> dict[str, Any]:
    out = {k: info[k] for k in ("n", "n_available", "thinning_step", "max_n")}
    out.update(dep)
    if "note" in info:
        out["note"] = info["note"]
    return out


def phase_block(
    energy: np.ndarray,
    mask: np.ndarray,
    *,
    dep: dict[str, Any],
    n_bootstrap: int,
    test_size: int | None,
    thin: str | int,
    alpha: float,
    seed: np.random.SeedSequence,
) -> tuple[dict[str, Any], PhaseComparison | None]:
    """compare_phases on ``energy[mask]`` with a thinned test sample."""
    rng = np.random.default_rng(seed)
    x = energy[mask]
    n_pos = int((x > 0).sum())
    if n_pos < MIN_SAMPLES:
        return {
            "n": int(x.size),
            "skipped": f"fewer than {MIN_SAMPLES} positive energies ({n_pos})",
        }, None
    positive = mask & (energy > 0)
    tx, info = draw_test_sample(
        energy, positive, max_n=test_size, thin=thin, step=dep["decorrelation_lag"], rng=rng
    )
    reuse = info["thinning_step"] == 1 and info["n"] == info["n_available"]
    if not reuse and tx.size < MIN_SAMPLES:
        tx = None
        reuse = True
        info = {**info, "n": n_pos, "thinning_step": 1, "note": "too few to thin"}
    cmp_ = compare_phases(
        x,
        test_x=None if reuse else tx,
        n_bootstrap=n_bootstrap,
        alpha=alpha,
        random_state=rng,
    )
    out = cmp_.to_dict()
    out["test_sample"] = test_sample_info(info, dep)
    return out, cmp_


def plausibility(
    block: dict[str, Any],
    kin: xr.Dataset,
    *,
    mass: float | None,
    max_plausible_speed: float | None,
) -> dict[str, Any]:
    """Whether each fitted temperature describes motion the animal can make.

    A temperature ``kT`` (per unit mass) is the mean energy ``<v^2>/2`` of its phase,
    so its root-mean-square speed is ``sqrt(2 kT)`` (``sqrt(2 kT / m)`` with a mass).
    The bound: ``max_plausible_speed`` (mm/s) when given (the animal's top speed),
    otherwise the implausible-motion threshold of the kinematics -- a phase whose
    typical speed is one that the data's own rule calls a tracking glitch describes
    glitches, not the animal.
    """
    rule = json.loads(kin.attrs.get("implausible_rule", "{}"))
    if max_plausible_speed is not None:
        bound = float(max_plausible_speed)
        source = "max_plausible_speed (the animal's top speed, given)"
    elif rule.get("threshold_mm_s"):
        bound = float(rule["threshold_mm_s"])
        source = f"implausible-motion threshold ({rule.get('rule')} rule)"
    else:
        bound, source = None, "none (no moving steps to set a scale)"
    temps: dict[str, dict[str, Any]] = {}
    if "one_phase" in block:
        named = [("kT", block["one_phase"].get("kT"))]
        if not block["two_phase"].get("degenerate"):
            named += [
                ("kT1", block["two_phase"].get("kT1")),
                ("kT2", block["two_phase"].get("kT2")),
            ]
        for name, kt in named:
            if kt is None or not np.isfinite(kt) or kt <= 0:
                continue
            rms = math.sqrt(2.0 * kt / mass) * 1e3 if mass else math.sqrt(2.0 * kt)
            temps[name] = {
                "value": kt,
                "rms_speed_mm_s": rms,
                "plausible": None if bound is None else bool(rms <= bound),
            }
    bad = [k for k, v in temps.items() if v["plausible"] is False]
    out: dict[str, Any] = {
        "bound_mm_s": bound,
        "bound_source": source,
        "rule": "a phase is plausible when its rms speed sqrt(2 kT) is at most the bound",
        "temperatures": temps,
        "all_plausible": None if bound is None else not bad,
    }
    if bad:
        out["warning"] = (
            f"implausible temperature(s) {', '.join(bad)}: rms speed "
            + ", ".join(f"{temps[k]['rms_speed_mm_s']:.4g}" for k in bad)
            + f" mm/s above {bound:.4g} mm/s ({source}); the fit describes tracking errors "
            "or mixes animals; check the frame rate, the units, identities and --max-speed"
        )
    return out
