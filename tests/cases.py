"""Inputs shared by many tests: the paper's disk as numbers for `inertiafit fit`, and the
attachment with a 3 kg disk as simulated bodies with their priors."""

#: `inertiafit fit` on the paper's 3 kg disk (Son et al., Table 3): inertia and gravity moment
#: with their standard errors.
DISK_FIT = [
    "fit",
    "--prior",
    "disk-3kg",
    "--inertia",
    "0.594",
    "--inertia-se",
    "0.0105",
    "--gravity-moment",
    "12.8",
    "--gravity-moment-se",
    "0.05",
]

#: Truth (mass kg, radius of gyration m, CoM distance m) of the simulated attachment and disk.
TRUTH = {"attachment": (2.85, 0.12, 0.24), "weight": (2.92, 0.0354, 0.45)}

#: Their priors: the nominal values, boxes of +-50 %.
PRIORS = {
    "attachment": {"mass": 2.91, "radius_of_gyration": 0.130, "com_distance": 0.225},
    "weight": {"mass": 2.92, "radius_of_gyration": 0.035, "com_distance": 0.45},
}

#: The path of the first fast trial of :func:`one_condition_study`.
ONE_CONDITION_FAST = "data/A_240_01.csv"


def one_condition_study(folder):
    """The attachment alone: a quasi-static trial (4 deg/s over 90 deg) and three fast trials
    at 240 deg/s (ramp 0.2-0.35 s, constant speed 0.35-0.57 s); the plausibility checks' and
    issue 22's catalogue's study. Returns ``folder``."""
    from inertiafit.simulate import simulate_study

    simulate_study(
        folder,
        bodies={"attachment": TRUTH["attachment"]},
        conditions=[("attachment",)],
        speeds=(240,),
        trials_per_speed=3,
        quasi_static_speed=4.0,
        seed=7,
        phi=0.2,
        offset=1.5,
        priors={"attachment": PRIORS["attachment"]},
    )
    return folder
