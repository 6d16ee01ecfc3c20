"""Paper part: step and ramp responses of the 3-flap accordion (paper Figs. 7-11)."""

from pathlib import Path


def run(out: Path) -> list[str]:
    raise NotImplementedError("folding simulation lands with issue #4")
