"""`LoopFoldReport`: the verdict on a closed-loop folding, with the branch it took and the closure drift."""

import dataclasses

import numpy as np

from ..simulation import AbstractFoldReport, FoldReport, FoldVerdict

# A crease counts as having chosen its side once it is this far from flat (rad).
BRANCH_ANGLE = float(np.radians(2.0))


@dataclasses.dataclass(frozen=True)
class LoopFoldReport(AbstractFoldReport):
    """A fold report (the fields of `origami_jax.simulation.AbstractFoldReport`) plus, for a pattern
    with closed loops:

    - `branch`: which way each crease went (+1 valley, −1 mountain, 0 flat), taken when it first got
      `BRANCH_ANGLE` from flat (the choice made leaving the flat state), `(m,)`;
      `intended_branch`: the pattern's; `wrong_creases`: the creases that went the other way;
      `stayed_flat`: the creases the pattern folds that never left flat (another branch too: at a
      vertex of degree six or more some branches leave creases flat).
    - `final_branch`: the same at the end of the run.
    - `bias`: the start's pre-fold (rad; 0: started flat, the inputs alone chose).
    - `closure_drift`: the largest closure residual of any loop over the run (rad): how far the
      integrated state left the constraint manifold.
    """

    branch: np.ndarray
    intended_branch: np.ndarray
    wrong_creases: tuple[int, ...]
    final_branch: np.ndarray
    bias: float
    closure_drift: float
    stayed_flat: tuple[int, ...] = ()

    @classmethod
    def from_report(cls, pattern, report: FoldReport, trajectory, bias: float) -> "LoopFoldReport":
        theta = np.asarray(trajectory.theta)
        finite = np.all(np.isfinite(theta), axis=1)
        theta = theta[finite] if np.any(finite) else np.zeros((1, theta.shape[1]))
        intended = np.asarray(report.intended_angles)
        intended_branch = np.where(np.abs(intended) < BRANCH_ANGLE, 0, np.sign(intended)).astype(
            int
        )
        past = np.abs(theta) >= BRANCH_ANGLE
        first = np.argmax(past, axis=0)
        chosen = np.sign(theta[first, np.arange(theta.shape[1])]).astype(int)
        branch = np.where(np.any(past, axis=0), chosen, 0)
        final = theta[-1]
        final_branch = np.where(np.abs(final) < BRANCH_ANGLE, 0, np.sign(final)).astype(int)
        wrong = tuple(
            int(j)
            for j in np.flatnonzero((branch != 0) & (intended_branch != 0))
            if branch[j] != intended_branch[j]
        )
        flat = tuple(int(j) for j in np.flatnonzero((branch == 0) & (intended_branch != 0)))
        drift = pattern.closure_residual(theta)
        fields = {f.name: getattr(report, f.name) for f in dataclasses.fields(AbstractFoldReport)}
        if report.verdict == FoldVerdict.MISFOLDED and (wrong or flat):
            fields["reason"] = "took another folding branch: " + _off_branch(wrong, flat)
        return cls(
            **fields,
            branch=branch,
            intended_branch=intended_branch,
            wrong_creases=wrong,
            final_branch=final_branch,
            bias=float(bias),
            closure_drift=float(np.max(drift)) if drift.size else 0.0,
            stayed_flat=flat,
        )

    def summary(self) -> str:
        lines = [super().summary()]
        start = "flat" if self.bias == 0 else f"pre-folded by {self.bias:.3g} rad"
        if self.wrong_creases or self.stayed_flat:
            # From flat every branch is open and the hinges' torques alone choose; a die is never
            # exactly flat, and a small pre-fold along the hinges' branch is how to say so.
            hint = (
                ", where the folding branches meet: pre-fold it along the hinges' branch with "
                "bias=0.05 in start_state and assess, or fold --bias 0.05"
                if self.bias == 0
                else ""
            )
            off = _off_branch(self.wrong_creases, self.stayed_flat)
            lines.append(f"branch: not the pattern's, {off} (started {start}{hint})")
        else:
            lines.append(f"branch: the pattern's (started {start})")
        lines.append(f"closure drift: {self.closure_drift:.2e} rad")
        return "\n".join(lines)


def _creases(numbers) -> str:
    return ", ".join(str(j) for j in numbers[:8]) + (" ..." if len(numbers) > 8 else "")


def _off_branch(wrong, flat) -> str:
    """How a folding left the pattern's branch, in words: the creases that went the other way
    (`wrong`) and those that never left flat (`flat`)."""
    parts = []
    if wrong:
        parts.append(
            f"crease(s) {_creases(wrong)} went the other way (mountain for valley or back)"
        )
    if flat:
        parts.append(f"crease(s) {_creases(flat)} stayed flat")
    return "; ".join(parts)
