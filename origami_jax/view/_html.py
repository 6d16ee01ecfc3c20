"""One self-contained HTML page per scene: three.js, the viewer and the data inlined, no network.

The page carries the bundled three.js build (`static/`, from three's npm release, MIT licence) as
inert text; a small loader turns it into blob-URL modules and imports the viewer, so the page works
from a file, offline, and inside a notebook's `iframe` alike. The scene travels as JSON with vertex
positions and fold angles as base64 float32 (frames × vertices × 3 floats).
"""

from __future__ import annotations

import base64
import html
import json
import os
import tempfile
import webbrowser
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ._scene import DEFAULT_MAX_FRAMES, Scene, triangulate
from ._sources import scene_from

THREE_VERSION = "0.185.0"
# Drawn thickness at least this fraction of the model's size (diagonal of its bounding box over all
# frames), so that thin membranes still read as plates.
MIN_DRAWN_THICKNESS = 0.004
IFRAME_HEIGHT = 640


@cache
def _static(name: str) -> str:
    return resources.files("origami_jax.view").joinpath("static", name).read_text(encoding="utf-8")


def _b64(values: np.ndarray) -> str:
    return base64.b64encode(np.ascontiguousarray(values, dtype="<f4").tobytes()).decode("ascii")


def _thickness(scene: Scene, extent: float) -> tuple[float, str]:
    unit = f" {scene.length_unit}" if scene.length_unit else ""
    floor = MIN_DRAWN_THICKNESS * extent
    if scene.thickness is None or scene.thickness == 0:
        return floor, "Thickness not given: panels drawn as plates 0.4% of the model's size thick."
    if scene.thickness >= floor:
        return scene.thickness, f"Thickness to scale ({scene.thickness:.3g}{unit})."
    return floor, (
        f"Thickness {scene.thickness:.3g}{unit}, drawn {floor / scene.thickness:.3g}× thicker "
        "to be visible."
    )


def scene_payload(scene: Scene) -> dict[str, Any]:
    """The JSON data the page reads (documented in `static/viewer.js`)."""
    lo = scene.vertices.min(axis=(0, 1))
    hi = scene.vertices.max(axis=(0, 1))
    center = (lo + hi) / 2
    extent = float(np.linalg.norm(hi - lo)) or 1.0
    thickness, note = _thickness(scene, extent)
    triangles = np.concatenate(
        [triangulate(scene.panel(p, 0)) + scene.offsets[p] for p in range(scene.n_panels)]
    )
    return {
        "title": scene.title,
        "nFrames": scene.n_frames,
        "nPanels": scene.n_panels,
        "nVertices": int(scene.offsets[-1]),
        "offsets": scene.offsets.tolist(),
        "triangles": triangles.ravel().tolist(),
        "vertices": _b64(scene.vertices - center),
        "times": scene.times.tolist(),
        "foldAngles": _b64(np.rad2deg(scene.fold_angles)),
        "hinges": scene.hinges.ravel().tolist(),
        "hingeNames": list(scene.hinge_names),
        "highlightHinges": np.nonzero(scene.highlight_hinges)[0].tolist(),
        "highlightPanels": np.nonzero(scene.highlight_panels)[0].tolist(),
        "fixedPanels": np.nonzero(scene.fixed_panels)[0].tolist(),
        "contacts": {
            "frames": scene.contact_frames.tolist(),
            "points": (scene.contact_points - center).ravel().tolist(),
        },
        "thickness": thickness,
        "thicknessNote": note,
        "extent": extent,
        "verdict": scene.verdict,
        "verdictLevel": scene.verdict_level,
        "lengthUnit": scene.length_unit,
        "timeUnit": scene.time_unit,
        "timeLabel": scene.time_label,
        "notes": list(scene.notes),
    }


_LOADER = """
(function () {
  var fail = function (error) {
    var box = document.createElement('div');
    box.className = 'error';
    box.textContent = 'The view could not start: ' + (error && error.stack || error);
    document.querySelector('#origami-app .viewport').appendChild(box);
    window.__origami = { ready: false, error: String(error) };
    console.error(error);
  };
  try {
    var text = function (id) { return document.getElementById(id).textContent; };
    var url = function (source) {
      return URL.createObjectURL(new Blob([source], { type: 'text/javascript' }));
    };
    var core = url(text('three-core'));
    var three = url(text('three-module').split('./three.core.min.js').join(core));
    var orbit = url(text('three-orbit').split("from 'three'").join("from '" + three + "'"));
    var app = url(text('origami-viewer').split('__THREE__').join(three).split('__ORBIT__').join(orbit));
    import(app).catch(fail);
  } catch (error) { fail(error); }
})();
"""

_BODY = """<div id="origami-app" tabindex="0">
  <div class="viewport"><div class="verdict"></div><div class="cameras"></div></div>
  <div class="bar">
    <button class="play" title="play / pause (space)">&#9654; play</button>
    <input class="slider" type="range" min="0" max="0" step="1" value="0" aria-label="frame">
    <span class="readout"></span>
    <label>speed <select class="speed">
      <option value="0.25">0.25&times;</option><option value="0.5">0.5&times;</option>
      <option value="1" selected>1&times;</option><option value="2">2&times;</option>
      <option value="4">4&times;</option></select></label>
    <label><input class="loop" type="checkbox" checked> loop</label>
  </div>
  <div class="side">
    <h1 class="title"></h1>
    <div class="plot-box"><h2>Fold angles</h2><canvas class="plot"></canvas>
      <div class="plot-legend"></div></div>
    <h2>Legend</h2>
    <ul class="legend">
      <li><span class="sw" style="background:#e8a33d"></span>panel front (+normal)</li>
      <li><span class="sw" style="background:#8fb3c9"></span>panel back</li>
      <li><span class="sw" style="background:#a9a9a9"></span>fixed (substrate)</li>
      <li><span class="sw" style="background:#e0457b"></span>highlighted panel (contact)</li>
      <li><span class="ln" style="background:#1f5fd6"></span>valley hinge
        <span class="ln" style="background:#d62828"></span>mountain
        <span class="ln" style="background:#444"></span>flat</li>
      <li><span class="ln" style="background:#ff9900"></span>highlighted hinge</li>
      <li><span class="sw" style="background:#e01010;border-radius:6px"></span>contact</li>
    </ul>
    <p class="units"></p>
    <ul class="notes"></ul>
    <p class="units">Drag to turn, wheel to zoom, right-drag to pan; space plays, arrows step.
      three.js r{version} (MIT) bundled.</p>
  </div>
</div>"""


def _script(kind: str, element_id: str, text: str) -> str:
    if "</script" in text.lower():
        raise ValueError(f"{element_id}: embedded text must not contain '</script'")
    return f'<script type="{kind}" id="{element_id}">\n{text}\n</script>'


def to_html(scene: Scene) -> str:
    """The page of `scene` as one HTML string (self-contained, works offline)."""
    payload = json.dumps(scene_payload(scene), allow_nan=False, separators=(",", ":"))
    payload = payload.replace("</", "<\\/")  # a valid JSON escape; keeps '</script' out
    return "\n".join(
        [
            "<!DOCTYPE html>",
            '<html lang="en"><head><meta charset="utf-8">',
            '<meta name="viewport" content="width=device-width, initial-scale=1">',
            f"<title>{html.escape(scene.title)} · origami_jax</title>",
            f"<style>\nhtml, body {{ margin: 0; padding: 0; }}\n{_static('viewer.css')}</style>",
            "</head><body>",
            _BODY.replace("{version}", THREE_VERSION.split(".")[1]),
            _script("application/json", "origami-scene", payload),
            _script("text/plain", "three-core", _static("three.core.min.js")),
            _script("text/plain", "three-module", _static("three.module.min.js")),
            _script("text/plain", "three-orbit", _static("OrbitControls.js")),
            _script("text/plain", "origami-viewer", _static("viewer.js")),
            "<script>window.__origami = { ready: false };</script>",
            _script("text/javascript", "origami-loader", _LOADER),
            "</body></html>",
        ]
    )


def _as_scene(obj: Any, **kwargs: Any) -> Scene:
    return scene_from(obj, **kwargs)


def write_html(obj: Any, path: str | os.PathLike, **kwargs: Any) -> Path:
    """Write the view of `obj` (a `Scene` or anything `scene_from` takes, with its `kwargs`) to
    `path`, atomically (a temporary file in the same folder, then `os.replace`). Returns the path."""
    path = Path(path)
    text = to_html(_as_scene(obj, **kwargs))
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            handle.write(text)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def open_in_browser(path: str | os.PathLike) -> bool:
    """Open a written page in the default web browser; `False` when none could be started."""
    return webbrowser.open(Path(path).resolve().as_uri())


class View:
    """A view for notebooks: displays inline (an `iframe` whose `srcdoc` is the whole page, so the
    same controls work in JupyterLab, Notebook, VS Code and exported HTML, offline).

    **Attributes:** `scene`, `html` (the page), `height` (pixels of the inline frame).
    """

    def __init__(self, scene: Scene, *, height: int = IFRAME_HEIGHT):
        self.scene = scene
        self.html = to_html(scene)
        self.height = int(height)

    def _repr_html_(self) -> str:
        return (
            f'<iframe srcdoc="{html.escape(self.html, quote=True)}" '
            f'style="width:100%;height:{self.height}px;border:1px solid #ddd" '
            f'title="{html.escape(self.scene.title)}"></iframe>'
        )

    def save(self, path: str | os.PathLike) -> Path:
        """Write the page to `path` (atomically)."""
        return write_html(self.scene, path)

    def __repr__(self) -> str:
        s = self.scene
        return f"View({s.title!r}: {s.n_panels} panels, {s.n_hinges} hinges, {s.n_frames} frames)"


def show(
    obj: Any, *, height: int = IFRAME_HEIGHT, max_frames: int | None = DEFAULT_MAX_FRAMES, **kwargs
) -> View:
    """The interactive view of `obj` for a notebook (a `View`; the last expression of a cell shows
    it). `obj` and `kwargs` as in `scene_from` (e.g. `system=` for a `Trajectory`)."""
    return View(_as_scene(obj, max_frames=max_frames, **kwargs), height=height)
