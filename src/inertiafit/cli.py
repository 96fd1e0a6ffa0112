"""Command line: ``inertiafit``."""


def main(argv=None) -> int:  # placeholder replaced below in this session
    raise SystemExit("not yet")
