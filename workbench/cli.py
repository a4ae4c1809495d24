"""Command line (placeholder until the problem registry lands)."""


def main() -> int:
    """Entry point."""
    return 0
