import matplotlib

matplotlib.use("Agg")

from hypothesis import HealthCheck, settings

# Property tests (tests/test_io_properties.py): the suite runs the "ci" profile, a few
# derandomised examples per test (the same every run); `make fuzz` runs the "fuzz" profile,
# many random examples (pytest --hypothesis-profile=fuzz).
settings.register_profile(
    "ci",
    max_examples=25,
    derandomize=True,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "fuzz",
    max_examples=1500,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.load_profile("ci")
