"""Checks of a pattern's panels that `fold` and `yield` make before anything compiles."""

import sys

import numpy as np

from .._limits import EXPLICIT_STABILITY, FOLD_MAX_STEPS, SLOW_EXPLICIT_STEPS
from ._common import fail

# Widest panel, in film thicknesses: beyond it float64 cannot resolve the film (and the contact
# gaps, a fraction of it) against the panel's coordinates (2e12 µm panels failed deep in the
# geometry with "x_axis is along the polygon's normal").
MAX_WIDTH_IN_THICKNESSES = 1e8


def check_has_creases(pattern, label: str) -> None:
    """Refuse (one line) a pattern without creases (a single face): nothing folds, and the
    estimates failed deep inside on empty arrays."""
    if pattern.n_creases == 0:
        fail(
            f"{label} has no creases (one face): nothing folds; give a net or pattern of at least "
            "two faces joined by a crease (an M or V edge)."
        )


def face_widths(geometry, length_scale: float) -> np.ndarray:
    """Each face's width, ``2 · area / perimeter`` (design length units, `(F,)`): half the side of
    a square panel, the inradius of a triangle; near 0 for a sliver."""
    coords = np.asarray(geometry.vertices_coords, dtype=float)
    plane = np.asarray(geometry.plane, dtype=float)
    widths = []
    for face in geometry.faces:
        xy = (coords[list(face)] - coords[face[0]]) @ plane.T
        x, y = xy[:, 0], xy[:, 1]
        area = 0.5 * abs(float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)))
        perimeter = float(np.sum(np.linalg.norm(xy - np.roll(xy, -1, axis=0), axis=1)))
        widths.append(2.0 * area / perimeter if perimeter > 0 else 0.0)
    return np.asarray(widths) * float(length_scale)


def check_panels_thicker_than_film(pattern, design, label: str) -> None:
    """Refuse (one line) a pattern with a panel narrower than the film it is made of
    (`design.t_structural`): the contact model's panels are that thick, and a sliver or a pattern
    drawn in the wrong unit ran for minutes to "ran out of steps"; or one wider than
    `MAX_WIDTH_IN_THICKNESSES` films."""
    thickness = float(np.max(np.asarray(design.t_structural, dtype=float)))
    widths = face_widths(pattern.geometry, pattern.length_scale)
    thin = np.flatnonzero(~(widths > thickness))
    if len(thin):
        face = int(thin[np.argmin(widths[thin])])
        fail(
            f"{label}: face {face} is {widths[face]:.3g} µm wide (2·area/perimeter), not wider "
            f"than the panels' film ({thickness:.3g} µm thick): merge or drop the sliver, or "
            "rescale the pattern (its frame_unit, or --length-scale for a unitless file)."
        )
    wide = int(np.argmax(widths))
    if widths[wide] > MAX_WIDTH_IN_THICKNESSES * thickness:
        fail(
            f"{label}: face {wide} is {widths[wide]:.3g} µm wide, more than "
            f"{MAX_WIDTH_IN_THICKNESSES:g} times the panels' film ({thickness:.3g} µm): float64 "
            "cannot resolve the film against it; rescale the pattern (its frame_unit, or "
            "--length-scale for a unitless file)."
        )


def warn_if_films_too_thick_to_close(pattern, design, label: str, tolerance_deg: float) -> None:
    """Warn (one line, standard error) where the panels' film is so thick against the smallest
    panel that point creases cannot close the pattern's seams within the crease tolerance: a point
    crease turns its panels about their mid-surfaces, so walls that meet stop short by about
    ``t / L`` (the film's thickness over the panel's size, ``L`` twice its width, `face_widths`:
    a square's side); the run then ends "jammed" for a reason worth knowing first."""
    if not len(pattern.geometry.target_seams):
        return
    thickness = float(np.max(np.asarray(design.t_structural, dtype=float)))
    size = 2.0 * float(np.min(face_widths(pattern.geometry, pattern.length_scale)))
    short = np.degrees(thickness / size)
    if short > tolerance_deg:
        print(
            f"origami-jax: warning: {label}: the panels' film ({thickness:.3g} µm) is "
            f"{100 * thickness / size:.2g} % of the smallest panel ({size:.3g} µm): point creases, "
            f"turning the panels about their mid-surfaces, close its seams only to within "
            f"~{short:.2g}°, more than the {tolerance_deg:g}° tolerance, so expect 'jammed' "
            "(physics guide: Plates thick against their panels).",
            file=sys.stderr,
        )


def check_targets(net, targets, label: str, design) -> None:
    """Refuse (one line) a crease aimed at 0 (flat) or so close to it that its hinge would be
    shorter than its film (`origami_jax.net.check_hinges_longer_than_film`): a stressed hinge's
    stiffness grows as 1/angle, and a zero angle gave "stiffness contains NaN or inf", a 1e-9° one
    a run of minutes."""
    from ..net import check_hinges_longer_than_film

    targets = np.asarray(net.intended_angles if targets is None else targets, dtype=float)
    flat = np.flatnonzero(targets == 0)
    if len(flat):
        j = int(flat[0])
        edges = ", ".join(map(str, net.crease_edge_ids[j]))
        fail(
            f"{label}: crease {j} (FOLD edge {edges}) folds to 0°: a stressed hinge folds to a "
            "non-zero angle; give its edges_foldAngle (or --targets), or assign it F (flat) to "
            "join its faces as one panel."
        )
    try:
        check_hinges_longer_than_film(design, targets, label, "its edges_foldAngle, or --targets")
    except ValueError as error:
        fail(str(error))


def check_explicit_steps(
    system,
    span: float,
    flag: str,
    loops: bool,
    budget: int = FOLD_MAX_STEPS,
    command: str = "fold",
) -> None:
    """Refuse (one line) an explicit (Tsit5) run of `span` µs that cannot end within the step
    `budget` (default the fold's), and say when it will be long: its steps are at most
    `EXPLICIT_STABILITY` over the stiffest hinge's rest frequency (about two thirds of its
    period; here its lower bound `FoldingSystem.stiffest_rest_frequency_bound`, which costs no
    compilation where the contact's defaults ran) however still the panels are, so ``span ω / 4``
    steps is a floor known before anything runs. `flag` names the span, `command` the run. Closed
    `loops` (constrained coordinates) are not estimated."""
    if loops or not system.mechanism.coordinates_are_hinge_angles:
        return
    fastest = system.stiffest_rest_frequency_bound()
    floor = span * fastest / EXPLICIT_STABILITY
    period = 2 * np.pi / fastest if fastest > 0 else np.inf
    if floor > budget:
        fail(
            f"{flag} ({span:g} µs) needs at least {floor:.3g} explicit steps (the stiffest hinge "
            f"rings with a period of at most {period:.3g} µs), more than the {budget:,} a "
            f"{command} may take: give a shorter run, or an implicit --solver (kvaerno5: steps as "
            "long as the motion allows)."
        )
    if floor > SLOW_EXPLICIT_STEPS:
        print(
            f"[{command}] note: the stiffest hinge rings with a period of at most {period:.3g} µs, "
            f"so this run takes at least {floor:,.0f} explicit steps (minutes); --solver kvaerno5 "
            "steps as long as the motion allows.",
            flush=True,
        )
