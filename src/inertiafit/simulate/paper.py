"""The experiment of Son et al. as a simulated study: its truth, its priors, its 62 trials."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from inertiafit.simulate.signals import Body, Noise
from inertiafit.simulate.study import simulate_study

__all__ = ["PAPER_PRIORS", "PAPER_TRUTH", "paper_study"]


#: True parameters used by :func:`paper_study` (kg, m, m): close to, not equal to, the nominal.
PAPER_TRUTH = {
    "attachment": Body(mass=2.85, radius_of_gyration=0.12, com_distance=0.24),
    "weight": Body(mass=2.92, radius_of_gyration=0.0354, com_distance=0.45),
}
#: Nominal priors of the paper's ideal shapes (Tables 2 and 3), +-50 % boxes.
PAPER_PRIORS = {
    "attachment": {
        "mass": 2.91,
        "radius_of_gyration": 0.130,
        "com_distance": 0.225,
        "spread": 0.5,
    },
    "weight": {"mass": 2.92, "radius_of_gyration": 0.035, "com_distance": 0.45, "spread": 0.5},
}


def paper_study(
    out_dir: str | Path,
    *,
    seed: int | None = 0,
    noise: Noise | None = None,
    phi: float = 0.0,
    offset: float = 0.0,
    **kwargs: Any,
) -> Path:
    """Write the experiment of Son et al.: attachment alone, then with the 3 kg disk.

    Two conditions (``attachment``; ``attachment + weight``), each with one quasi-static trial
    at 1 deg/s over 0-90 deg and ten fast trials at each of 240, 270 and 300 deg/s: 62 trials
    at 1 kHz. The truth is :data:`PAPER_TRUTH`; the manifest's priors are the paper's ideal
    values (:data:`PAPER_PRIORS`). The default noise is :meth:`Noise.paper`, whose
    trial-to-trial scatter of the attachment's inertia is close to the paper's.

    Parameters
    ----------
    out_dir : str or Path
        Folder to write into.
    seed : int, optional
        Seed.
    noise : Noise, optional
        Default :meth:`Noise.paper`.
    phi, offset : float
        Device phase (rad) and torque offset (N m).
    **kwargs
        Further keywords of :func:`simulate_study` (units, ``motion``, ``priors``...).

    Returns
    -------
    Path
        The manifest ``study.toml``.
    """
    bodies = {
        b: (body.mass, body.radius_of_gyration, body.com_distance)
        for b, body in PAPER_TRUTH.items()
    }
    kwargs.setdefault("priors", PAPER_PRIORS)
    kwargs.setdefault("name", "Son et al.: elbow attachment with a 3 kg disk (simulated)")
    return simulate_study(
        out_dir,
        bodies=bodies,
        conditions=[("attachment",), ("attachment", "weight")],
        seed=seed,
        noise=Noise.paper() if noise is None else noise,
        phi=phi,
        offset=offset,
        **kwargs,
    )
