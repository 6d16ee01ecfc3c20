"""`scene_from`: one entry point from any object or result file of the package to a `Scene`.

Objects: `Scene`, `FoldFile`, `UnfoldResult`, `SingleVertex`, `Trajectory` (with its system, or its
pattern and design), `SlowRampResult`, a pattern (`origami_jax.system.AbstractPattern`: `Net`,
`CreasePattern`, `Accordion`; flat and folded as intended), `FoldingSystem` or a mechanism (with
states), a sweep dataset (with a member).
Files: `.fold` (any FOLD file with frames), the `path.npz` of `origami-jax unfold`, the
`trajectory.csv`/`.npz` of `origami-jax simulate` (its `metrics.json` beside it gives the design),
the `sweep.nc` of an "accordion-step" `origami-jax sweep` (a member is rebuilt and simulated). A
file's stored names (the simulate command's `--param`s, a sweep's model and settings) become a pattern
once, here (`simulated_pattern`, `sweep_member_pattern`); the system is built through it.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from ..fold import FoldFormatError
from ._adapters import (
    pattern_panel_thickness,
    scene_from_mechanism,
    scene_from_pattern,
    scene_from_trajectory,
    scene_from_unfold_npz,
    scene_from_unfolding,
    scene_from_vertex_path,
)
from ._fold_scene import scene_from_fold
from ._scene import DEFAULT_MAX_FRAMES, Scene, resample


def _is(obj: Any, module: str, name: str) -> bool:
    """`isinstance(obj, module.name)` without importing `module` (an instance means it is loaded)."""
    loaded = sys.modules.get(module)
    cls = getattr(loaded, name, None) if loaded is not None else None
    return cls is not None and isinstance(obj, cls)


def scene_from(
    obj: Any,
    *,
    system: Any = None,
    pattern: Any = None,
    design: Any = None,
    states: Any = None,
    member: int | None = None,
    thickness: float | None = None,
    report: Any = None,
    max_frames: int | None = DEFAULT_MAX_FRAMES,
    title: str | None = None,
) -> Scene:
    """A `Scene` of `obj`, with at most `max_frames` frames (`None`: all).

    **Arguments:**
    - `obj`: a `Scene`, `FoldFile`, `UnfoldResult`, `SingleVertex`, `Trajectory`, `SlowRampResult`,
      a pattern (`Net`, `CreasePattern`, `Accordion`: flat, then folded to its intended angles,
      `scene_from_pattern`), `FoldingSystem`/mechanism, sweep `xarray.Dataset`, or a path to a
      result file (module doc).
    - `system`: the `FoldingSystem` (or mechanism) a `Trajectory` was simulated with; or instead
      `pattern` (an `origami_jax.system.AbstractPattern`) and `design` (its `HingeDesign`,
      default the pattern's): the system is `pattern.system(design)`. `design` also builds a
      pattern given as `obj`.
    - `states`: `(T, n_coordinates)` states of a `FoldingSystem`/mechanism (default its rest state).
    - `member`: the design index of a sweep dataset or `sweep.nc`.
    - `thickness`: panel thickness of a mechanism, its length unit (files give their own).
    - `report`: the `FoldReport` of a net's or crease pattern's `Trajectory` (`assess`): the
      verdict banner and the creases outside tolerance highlighted.
    - `title`: the page's title.

    **Raises:** `ValueError` with what is missing (a trajectory without its system, a sweep without
    a member, an unknown file type).
    """
    kwargs: dict[str, Any] = {} if title is None else {"title": title}
    if pattern is not None:
        if system is not None:
            raise ValueError(
                "give system= or pattern= (its system is pattern.system(design)), not both"
            )
        if not _is(pattern, "origami_jax.system._pattern", "AbstractPattern"):
            raise ValueError(
                f"pattern= takes a Net, CreasePattern or Accordion, got {type(pattern).__name__}"
            )
        design = pattern.default_design() if design is None else design
        system = pattern.system(design)
        if thickness is None:
            thickness = pattern_panel_thickness(design)
    if isinstance(obj, Scene):
        scene = obj if title is None else obj.replace(title=title)
    elif isinstance(obj, str | os.PathLike):
        scene = load_scene(Path(obj), member=member, **kwargs)
    elif _is(obj, "origami_jax.fold._model", "FoldFile"):
        scene = scene_from_fold(obj, **kwargs)
    elif _is(obj, "origami_jax.vertex._unfold", "UnfoldResult"):
        scene = scene_from_unfolding(obj, **kwargs)
    elif _is(obj, "origami_jax.vertex._unfold", "BatchResult"):
        raise ValueError(
            "unfold_batch keeps end states only, not paths: unfold(vertex) the member you want to "
            "see and view that result"
        )
    elif _is(obj, "origami_jax.vertex._model", "SingleVertex"):
        scene = scene_from_vertex_path(
            np.asarray(obj.directions),
            np.asarray(obj.sector_angles),
            closed=bool(obj.closed),
            **kwargs,
        )
    elif _is(obj, "origami_jax.simulation._slow_ramp", "SlowRampResult"):
        return scene_from(
            obj.trajectory,
            system=system,
            thickness=thickness,
            report=report,
            max_frames=max_frames,
            title=title,
        )
    elif _is(obj, "origami_jax.simulation._simulate", "Trajectory"):
        if system is None:
            raise ValueError(
                "a Trajectory does not hold its system: pass system=, the FoldingSystem it was "
                "simulated with"
            )
        scene = scene_from_trajectory(obj, system, thickness=thickness, report=report, **kwargs)
    elif _is(obj, "origami_jax.system._pattern", "AbstractPattern"):
        scene = scene_from_pattern(obj, design, thickness=thickness, **kwargs)
    elif _is(obj, "origami_jax.system._system", "FoldingSystem") or _is(
        obj, "origami_jax.system._mechanism", "AbstractMechanism"
    ):
        scene = scene_from_mechanism(obj, states, thickness=thickness, **kwargs)
    elif _is(obj, "xarray.core.dataset", "Dataset"):
        scene = scene_from_sweep_member(obj, member, **kwargs)
    else:
        raise ValueError(
            f"cannot view a {type(obj).__name__}: give a FOLD file or FoldFile, an UnfoldResult, "
            "a Trajectory with system= (or pattern=), a pattern (Net, CreasePattern, Accordion), "
            "a FoldingSystem, a sweep dataset with member=, or a Scene"
        )
    return resample(scene, max_frames)


# What a file that cannot be read raises: a truncated CSV (ValueError), NPZ (BadZipFile, EOFError),
# NetCDF (OSError) or a missing array (KeyError).
_UNREADABLE = (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile)


def load_scene(path: Path, *, member: int | None = None, title: str | None = None) -> Scene:
    """A scene of a result file (see the module docstring); `ValueError` for what cannot be read
    (a folder, a file cut short, a file of another command), naming the file to give instead."""
    path = Path(path)
    if path.is_dir():
        raise ValueError(_folder_message(path))
    if not path.is_file():
        raise ValueError(f"no such file: {path}")
    return _load_scene(path, member=member, title=title)


@contextlib.contextmanager
def _reading(path: Path):
    """Errors of reading `path` (a truncated CSV, NPZ, NetCDF or JSON file; a missing array) as one
    `ValueError` saying the file is cut short, instead of the library's own words."""
    try:
        yield
    except _UNREADABLE as error:
        text = str(error).splitlines()[0] if str(error) else ""
        raise ValueError(
            f"cannot read {path} ({type(error).__name__}: {text[:160]}): it is cut short or not a "
            "result file; write it again (rerun the command)"
        ) from None


# Result files a command's folder holds, in the order `view` suggests them.
_VIEWABLE = ("trajectory.fold", "path.npz", "trajectory.csv", "trajectory.npz", "sweep.nc")


def _folder_message(path: Path) -> str:
    found = [name for name in _VIEWABLE if (path / name).is_file()]
    if found:
        return f"{path} is a folder: give the result file in it, e.g. {path / found[0]}"
    return (
        f"{path} is a folder: give a result file (a .fold file, the path.npz of unfold, the "
        "trajectory.csv of simulate, the trajectory.fold of fold, or a sweep.nc with --member)"
    )


def _load_scene(path: Path, *, member: int | None = None, title: str | None = None) -> Scene:
    suffix = path.suffix.lower()
    kwargs = {} if title is None else {"title": title}
    if suffix == ".fold":
        try:
            return scene_from_fold(path, **kwargs)
        except FoldFormatError as error:
            message = str(error)  # the reader names the file already, most of the time
            named = message.startswith(f"{path}:")
            raise ValueError(message if named else f"{path}: {message}") from error
    if suffix == ".nc":
        import xarray as xr

        with _reading(path), xr.open_dataset(path) as dataset:
            loaded = dataset.load()
        return scene_from_sweep_member(loaded, member, **kwargs)
    if suffix in (".csv", ".npz"):
        _refuse_other_commands(path)
    if suffix == ".npz":
        # Through our own handle: NumPy leaves its own open when the archive is cut short.
        with _reading(path), path.open("rb") as handle, np.load(handle, allow_pickle=False) as data:
            keys = set(data.files)
            arrays = {k: data[k] for k in ("times", "theta") if k in keys}
        if "directions" in keys:
            with _reading(path):
                scene = scene_from_unfold_npz(path)
            return scene if title is None else scene.replace(title=title)
        if "theta" in keys:
            with _reading(path):
                times, theta = arrays["times"], arrays["theta"]
            return _simulated_file(path, times, theta, **kwargs)
    if suffix == ".csv":
        with _reading(path), path.open(encoding="utf-8") as handle:
            header = handle.readline()
        if header.startswith("time"):
            columns = header.strip().split(",")
            with _reading(path):
                data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
            theta = [i for i, c in enumerate(columns) if c.startswith("theta_") and "dot" not in c]
            return _simulated_file(path, data[:, 0], data[:, theta], **kwargs)
    raise ValueError(
        f"cannot view {path.name}: give a .fold file, the path.npz of `origami-jax unfold`, the "
        "trajectory.csv/.npz of `origami-jax simulate` or a sweep.nc with --member"
    )


def _refuse_other_commands(path: Path) -> None:
    """A trajectory file beside another command's results than `simulate`'s: `fold` writes a
    `trajectory.csv` of hinge angles too, which `view` would draw as an accordion."""
    if path.with_name("metrics.json").is_file():
        return
    fold = path.with_name("trajectory.fold")
    if fold.is_file() or path.with_name("result.json").is_file():
        raise ValueError(
            f"{path.name} beside result.json is the hinge angles of a `fold` run, not of a chain "
            f"`simulate` run: view {fold}, which holds the folding"
        )


def simulated_pattern(report: dict, flaps: int) -> tuple[Any, Any]:
    """The accordion and the design of an `origami-jax simulate` run, from its `metrics.json`
    (`report`: `fluid` and the `--param` values, flap size among them; `{}` gives the
    literature design): `(Accordion, HingeDesign)`. **Raises:** `ValueError` for values the
    design or the pattern refuses."""
    from ..chain import ACCORDION_GEOMETRY, Accordion
    from ..system import AIR, KOH_SOLUTION, HingeDesign

    params = dict(report.get("params", {}))
    geometry = {k: params.pop(k) for k in ACCORDION_GEOMETRY if k in params}
    fluid = KOH_SOLUTION if "KOH" in str(report.get("fluid", "")) else AIR
    try:
        design = HingeDesign.literature(fluid=fluid, **params)
    except TypeError as error:  # a name the design does not take
        raise ValueError(f"metrics.json params: {error}") from None
    return Accordion(flaps, **geometry), design


def _simulated_file(path: Path, times, theta, *, title: str | None = None) -> Scene:
    """A trajectory file of `origami-jax simulate`: the accordion rebuilt from `metrics.json`."""
    theta = np.asarray(theta, dtype=float)
    metrics_path = path.with_name("metrics.json")
    notes = []
    report: dict[str, Any] = {}
    if metrics_path.is_file():
        with _reading(metrics_path):
            report = json.loads(metrics_path.read_text(encoding="utf-8"))
        if not isinstance(report, dict):
            raise ValueError(f"{metrics_path} is not simulate's metrics (not a JSON object)")
    else:
        notes.append(f"no {metrics_path.name} beside the file: literature design assumed")
    samples, t1 = report.get("samples"), report.get("t1")
    times = np.asarray(times, dtype=float)
    cut = samples is not None and len(times) != samples
    if t1 is not None and len(times) and not math.isclose(times[-1], t1, rel_tol=1e-9):
        cut = True  # the file holds its times to 12 significant digits
    if cut:
        said = f"{samples} samples" if samples is not None else "another end"
        said += f" to {t1:g} µs" if t1 is not None else ""
        # A copy cut at a row boundary reads as a shorter run, which would show as successful.
        raise ValueError(
            f"{path.name} holds {len(times)} samples to {float(times[-1]):g} µs but "
            f"{metrics_path.name} says {said}: the file is cut short; write it again (rerun "
            "simulate)"
        )
    flaps = int(report.get("flaps", theta.shape[1]))
    if flaps != theta.shape[1]:
        raise ValueError(f"{metrics_path} says {flaps} flaps but {path.name} has {theta.shape[1]}")
    pattern, design = simulated_pattern(report, flaps)
    system = pattern(design)
    scene = scene_from_mechanism(
        system,
        theta,
        times=np.asarray(times, dtype=float),
        thickness=float(design.t_structural),
        title=title or f"{flaps}-flap accordion ({path.name})",
    )
    if report:
        ok = bool(report.get("succeeded", True))
        text = f"solve {report.get('result', 'successful')}"
        level = "ok" if ok else "fail"
        if ok and len(scene.contact_frames):
            text += "; adjacent flaps reach each other (|θ| ≥ π): contacts marked"
            level = "warn"
        scene = scene.replace(verdict=text, verdict_level=level)
    return scene.replace(time_unit="µs", notes=(*scene.notes, *notes))


def sweep_member_system(dataset: Any, member: int | None) -> tuple[Any, Any, dict, str]:
    """Rebuild design `member` of an "accordion-step" sweep dataset as the sweep kernel did:
    `sweep_member_pattern`'s pattern built with its design.

    **Returns:** `(system, design, settings, description)`. **Raises:** `ValueError` for another
    model, a missing or out-of-range member.
    """
    pattern, design, settings, description = sweep_member_pattern(dataset, member)
    return pattern(design), design, settings, description


def sweep_member_pattern(dataset: Any, member: int | None) -> tuple[Any, Any, dict, str]:
    """Design `member` of an "accordion-step" sweep dataset as the sweep kernel had it: the stored
    model name and settings turned into the pattern (an `origami_jax.chain.Accordion` with the
    member's flap count and flap size) and its `HingeDesign`.

    **Returns:** `(pattern, design, settings, description)`. **Raises:** `ValueError` for another
    model, a missing or out-of-range member.
    """
    from .._kernel import FLUIDS
    from ..chain import ACCORDION_GEOMETRY, ACCORDION_PARAMETERS, Accordion
    from ..system import AIR, KOH_SOLUTION, MICRO, Fluid, HingeDesign

    model = dataset.attrs.get("model")
    if model != "accordion-step":
        raise ValueError(
            f"only accordion-step sweeps can be viewed (this one is {model!r}); a vertex-unfold "
            "member can be unfolded again with origami_jax.vertex.unfold"
        )
    designs = np.asarray(dataset["design"].values)
    if member is None:
        raise ValueError(
            f"give the member to view (--member K): the sweep has {len(designs)} designs, "
            f"numbered {designs.min()} to {designs.max()}"
        )
    if member not in designs:
        raise ValueError(
            f"member {member} is not in the sweep: its designs are numbered "
            f"{designs.min()} to {designs.max()}"
        )
    row = dataset.sel(design=member)
    settings = json.loads(dataset.attrs["settings"])
    values = dict(settings["defaults"])
    values.update(k_scale=values.get("k_scale", 1.0), b_scale=values.get("b_scale", 1.0))
    swept = {}
    for name in ACCORDION_PARAMETERS:
        if name in row.coords:
            value = row.coords[name].values.item()
            swept[name] = value
            if name not in ("n_flaps", "fluid"):
                values[name] = float(value)
    n_flaps = int(swept.get("n_flaps", settings["n_flaps"]))
    fluid_name = swept.get("fluid", settings["fluid"])
    if not isinstance(fluid_name, str):
        fluid_name = FLUIDS[int(fluid_name)]
    base_fluid = {"air": AIR, "koh": KOH_SOLUTION}[fluid_name]
    for name, value in values.items():
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"member {member} has {name} = {value}: outside the model's domain")
    pattern = Accordion(n_flaps, **{k: values.pop(k) for k in ACCORDION_GEOMETRY if k in values})
    design = HingeDesign(
        **values,
        fluid=Fluid(base_fluid.to(MICRO).density, MICRO, fluid_name),
        stiffness_model=settings["stiffness_model"],
        drag_model=settings["drag_model"],
        units=MICRO,
    )
    description = ", ".join(
        f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in swept.items()
    )
    return pattern, design, settings, f"sweep member {member}: {n_flaps} flaps, {description}"


def scene_from_sweep_member(dataset: Any, member: int | None, *, title: str | None = None) -> Scene:
    """Design `member` of an "accordion-step" sweep, rebuilt and simulated again (a step input,
    the sweep's settings: end time, samples, tolerances, solver), as a scene."""
    import diffrax

    from ..simulation import SaveAt, SolveOptions, Step, implicit_solver, simulate

    pattern, design, settings, description = sweep_member_pattern(dataset, member)
    system = pattern(design)
    solver = {"kvaerno5": implicit_solver, "tsit5": diffrax.Tsit5}[settings["solver"]]()
    options = SolveOptions(
        t1=settings["t_end_us"],
        saveat=SaveAt(n=settings["n_save"]),
        solver=solver,
        rtol=settings["rtol"],
        atol=settings["atol"],
        max_steps=settings["max_steps"],
        throw=False,
    )
    trajectory = simulate(system, Step(), options)
    scene = scene_from_trajectory(
        trajectory, system, thickness=float(design.t_structural), title=title or description
    )
    stored = int(dataset["result"].sel(design=member).values)
    if stored != 0:
        scene = scene.replace(
            notes=(*scene.notes, f"the sweep stored result code {stored} for this member")
        )
    return scene
