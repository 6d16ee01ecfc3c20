"""Did it fold? A verdict on a simulated folding, with the numbers behind it.

`assess(system, trajectory)` compares the end of a simulation with the shape the device is meant to take:

- **folded**: every crease within `angle_tolerance` of its intended angle and every seam closed (gap
  below `seam_tolerance`); `time_to_fold` is when it got there for good.
- **jammed**: the device came to rest short of that, with panels in contact: a crease stopped short
  of its intended angle (same sign, smaller magnitude) while contact holds it.
- **misfolded**: it came to rest in another state (a crease on the wrong side or past its angle, seams
  open without contact to explain it, a different stacking).
- **unfinished**: time ran out (the solver's step budget, or still moving at the end of the run).
- **invalid**: the simulation failed (non-finite state or another solver failure): see `reason`.

"Intended" angles default to the system's hinge targets; for a net they are the crease pattern's fold
angles (a net whose hinges aim elsewhere, 80° instead of 90° say, is judged against the shape it should
take, not against its hinges). Host-side (NumPy) after the compiled simulation.
"""

import dataclasses
import enum
from collections.abc import Callable

import jax
import numpy as np

from ._results import RESULTS
from ._simulate import Trajectory


class FoldVerdict(enum.StrEnum):
    """Outcome of a folding (a `str`: `report.verdict == "folded"` works)."""

    FOLDED = "folded"
    JAMMED = "jammed"
    MISFOLDED = "misfolded"
    UNFINISHED = "unfinished"
    INVALID = "invalid"


@dataclasses.dataclass(frozen=True)
class FoldReport:
    """The verdict and the numbers behind it (host values; angles rad, lengths and times in the
    system's units).

    **Fields:**
    - `verdict`: a `FoldVerdict`; `reason`: one line why.
    - `final_angles`, `intended_angles`, `angle_errors`: per crease `(h,)`.
    - `seam_gaps`: largest gap of each seam at the end `(s,)` (empty without seams);
      `seam_tolerance`, `angle_tolerance`.
    - `time_to_fold`: first time from which every crease stays within tolerance (and every seam
      closed) to the end, or `None`.
    - `settled`: the last tenth of the run moved every crease by less than half the tolerance.
    - `contacts`: engaged (point, face) pairs at the end; `min_gap`: the smallest contact gap over the
      run (`inf` without contact); `max_penetration`: the largest penetration over the run (length)
      and `penetration_fraction` of the panel thickness (0 is the model's aim; both 0 without
      contact).
    - `result`: the solver's result message.
    """

    verdict: FoldVerdict
    reason: str
    final_angles: np.ndarray
    intended_angles: np.ndarray
    angle_errors: np.ndarray
    seam_gaps: np.ndarray
    angle_tolerance: float
    seam_tolerance: float
    time_to_fold: float | None
    settled: bool
    contacts: int
    min_gap: float
    max_penetration: float
    penetration_fraction: float
    result: str

    def to_dict(self) -> dict:
        """JSON-ready dictionary (non-finite numbers as `None`)."""

        def clean(x):
            if isinstance(x, np.ndarray):
                return [clean(v) for v in x.tolist()]
            if isinstance(x, list):
                return [clean(v) for v in x]
            if isinstance(x, float):
                return x if np.isfinite(x) else None
            return x

        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["verdict"] = str(self.verdict)
        return {k: clean(v) for k, v in out.items()}

    def summary(self) -> str:
        """A few lines for people (angles in degrees)."""
        lines = [f"verdict: {self.verdict} ({self.reason})"]
        errors = np.degrees(self.angle_errors)
        lines.append(
            f"creases: {len(errors)}, largest error {np.max(np.abs(errors)):.3g}° "
            f"(tolerance {np.degrees(self.angle_tolerance):.3g}°)"
        )
        if len(self.seam_gaps):
            lines.append(
                f"seams: {len(self.seam_gaps)}, largest gap {np.max(self.seam_gaps):.3g} "
                f"(tolerance {self.seam_tolerance:.3g})"
            )
        if self.time_to_fold is not None:
            lines.append(f"time to fold: {self.time_to_fold:.4g}")
        if np.isfinite(self.min_gap):
            lines.append(
                f"contact: {self.contacts} pairs engaged at the end, smallest gap "
                f"{self.min_gap:.3g}, max penetration {self.max_penetration:.3g} "
                f"({100 * self.penetration_fraction:.3g} % of the thickness)"
            )
        return "\n".join(lines)


def assess(
    system,
    trajectory: Trajectory,
    *,
    intended_angles=None,
    seam_gaps: Callable[[np.ndarray], np.ndarray] | None = None,
    angle_tolerance: float = float(np.radians(3.0)),
    seam_tolerance: float | None = None,
    thickness: float | None = None,
) -> FoldReport:
    """The verdict on a simulated folding (module docstring).

    **Arguments:**
    - `system`, `trajectory`: the [`origami_jax.system.FoldingSystem`][] and its simulation (one, not
      batched).
    - `intended_angles`: the fold angle each crease should reach (rad, `(h,)`); default the system's
      hinge targets.
    - `seam_gaps`: a function of the hinge angles `(h,)` returning each seam's gap (length, `(s,)`),
      e.g. from a net's geometry; `None` for a device without seams.
    - `angle_tolerance`: rad (default 3°); `seam_tolerance`: length (default 1 % of the largest panel,
      or 1 length unit without contact geometry).
    - `thickness`: panel thickness for `penetration_fraction` (default: twice the contact model's
      smallest half thickness).

    **Returns:** a `FoldReport`.
    """
    if trajectory.theta.ndim != 2:
        raise ValueError(
            "assess takes one trajectory; for a batch, assess each member (or use the sweep's "
            "verdict outputs)."
        )
    times = np.asarray(trajectory.times)
    theta = np.asarray(trajectory.theta)
    intended = np.asarray(
        system.hinges.target if intended_angles is None else intended_angles, dtype=float
    )
    if intended.shape != theta.shape[-1:]:
        raise ValueError(
            f"intended_angles must have shape {theta.shape[-1:]}, got {intended.shape}."
        )
    result = RESULTS[trajectory.result]
    contact = system.contact
    min_gap, penetration, engaged, fraction = np.inf, 0.0, 0, 0.0
    if contact is not None:
        finite = np.all(np.isfinite(theta), axis=-1)
        q = trajectory.theta if trajectory.state is None else trajectory.state[0]
        report = jax.device_get(jax.vmap(lambda q: contact.report(system.mechanism, q))(q))
        gaps = np.where(finite, report["min_gap"], np.inf)
        min_gap = float(np.min(gaps))
        penetration = float(np.max(np.where(finite, report["penetration"], 0.0)))
        engaged = int(np.asarray(report["engaged"])[-1]) if finite[-1] else 0
        if thickness is None:
            thickness = 2 * float(np.min(contact.tables.half_thickness))
        fraction = penetration / thickness if thickness else 0.0
        if seam_tolerance is None:
            seam_tolerance = 0.01 * contact.tables.scale
    if seam_tolerance is None:
        seam_tolerance = 1.0
    final = theta[-1]
    errors = final - intended
    gaps_final = (
        np.zeros(0) if seam_gaps is None or not np.all(np.isfinite(final)) else seam_gaps(final)
    )
    gaps_final = np.asarray(gaps_final, dtype=float)

    def report(verdict, reason, settled=False, time_to_fold=None):
        return FoldReport(
            verdict=verdict,
            reason=reason,
            final_angles=final,
            intended_angles=intended,
            angle_errors=errors,
            seam_gaps=gaps_final,
            angle_tolerance=float(angle_tolerance),
            seam_tolerance=float(seam_tolerance),
            time_to_fold=time_to_fold,
            settled=settled,
            contacts=engaged,
            min_gap=min_gap,
            max_penetration=penetration,
            penetration_fraction=float(fraction),
            result="successful" if result == "" else str(result),
        )

    if not bool(trajectory.succeeded):
        code = trajectory.result
        if code == RESULTS.max_steps_reached:
            return report(FoldVerdict.UNFINISHED, f"the solver ran out of steps ({result})")
        return report(FoldVerdict.INVALID, f"the simulation failed: {result}")

    within = np.all(np.abs(theta - intended) < angle_tolerance, axis=-1)
    if seam_gaps is not None:
        closed = np.array([np.all(np.asarray(seam_gaps(t)) < seam_tolerance) for t in theta])
        within &= closed
    tail = max(2, len(times) // 10)
    settled = bool(np.max(np.abs(theta[-tail:] - final)) < angle_tolerance / 2)
    time_to_fold = None
    if within[-1]:
        first = len(within) - int(np.argmin(within[::-1])) if not np.all(within) else 0
        time_to_fold = float(times[min(first, len(times) - 1)])
    if within[-1]:
        return report(
            FoldVerdict.FOLDED,
            "every crease at its angle, every seam closed",
            settled,
            time_to_fold,
        )
    if not settled:
        return report(FoldVerdict.UNFINISHED, "still moving at the end of the run", settled)
    short = (np.abs(final) < np.abs(intended) - angle_tolerance) & (
        np.sign(final) * np.sign(intended) >= 0
    )
    if np.any(short) and engaged > 0:
        creases = ", ".join(str(i) for i in np.nonzero(short)[0])
        return report(FoldVerdict.JAMMED, f"contact stops crease(s) {creases} short", settled)
    worst = int(np.argmax(np.abs(errors)))
    if np.all(np.abs(errors) < angle_tolerance):
        why = "creases at their angles but seams open"
    else:
        why = (
            f"crease {worst} at {np.degrees(final[worst]):.1f}° instead of "
            f"{np.degrees(intended[worst]):.1f}°"
        )
    return report(FoldVerdict.MISFOLDED, why, settled)
